"""Loads a `sweep run --format sqlite` trajectory with PedPy and computes the classic measures.

Run through `scripts/pedpy-check`, which makes the virtual environment. Defaults are the
paper scene: a line across its door (4.4 <= y <= 5.6) at x = 9.85, and a 2 m x 2 m square
in front of the door.

Why 9.85 and not the door's own x = 10: a person is written while their disk is not wholly
outside the room, i.e. until their centre is a radius (0.2 m) past the door, and PedPy's N-t
does not count a crossing that ends in a person's last frame; people pushed through the door
cover that 0.2 m in one frame at 10 fps, so a line on the door itself misses a third of them
(measured: 98 of 150). At three quarters of a radius inside (x = 9.85) everyone is written for
0.35 m after crossing, two frames up to 1.75 m/s, and the walls already keep every centre
within the door's width there, so nobody passes beside the line (measured: 150 of 150; at
x = 9.8 people can cut the corner beside a 1.2 m line, at 9.9 the fastest are missed).

    python pedpy_check.py TRAJECTORY.sqlite PLOT.png [--door X0,Y0,X1,Y1] [--area X0,Y0,X1,Y1]
"""

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np
import pedpy


def floats(text):
    values = [float(v) for v in text.split(",")]
    if len(values) != 4:
        raise argparse.ArgumentTypeError(f"expected 4 numbers, got {text!r}")
    return values


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("trajectory", type=pathlib.Path)
    parser.add_argument("plot", type=pathlib.Path)
    parser.add_argument("--door", type=floats, default=[9.85, 4.4, 9.85, 5.6],
                        help="measurement line x0,y0,x1,y1 (default: across the paper scene's door)")
    parser.add_argument("--area", type=floats, default=[8.0, 4.0, 10.0, 6.0],
                        help="measurement square x0,y0,x1,y1 (default: 2 m x 2 m before the door)")
    parser.add_argument("--frame-step", type=int, default=5,
                        help="frames before and after for individual speeds (default 5)")
    args = parser.parse_args()

    # The recipe: two calls load the trajectory and the walkable area from the file.
    traj = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=args.trajectory)
    walkable_area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=args.trajectory)
    data = traj.data
    print(f"pedpy {pedpy.__version__}: {args.trajectory}")
    print(f"  frames {data.frame.min()}..{data.frame.max()} at {traj.frame_rate:g} fps, "
          f"{data.id.nunique()} people, {len(data)} rows")
    print(f"  walkable area {walkable_area.area:.4f} m^2, bounds {walkable_area.bounds}")
    print(f"  every position inside the walkable area: "
          f"{pedpy.is_trajectory_valid(traj_data=traj, walkable_area=walkable_area)}")

    x0, y0, x1, y1 = args.door
    line = pedpy.MeasurementLine([(x0, y0), (x1, y1)])
    ax0, ay0, ax1, ay1 = args.area
    area = pedpy.MeasurementArea([(ax0, ay0), (ax1, ay0), (ax1, ay1), (ax0, ay1)])

    # Classic density in the square: people inside / its area, per frame.
    density = pedpy.compute_classic_density(traj_data=traj, measurement_area=area)
    density["time"] = density.frame / traj.frame_rate
    crowded = density[density.density > 0]
    print(f"density in the {ax1 - ax0:g} m x {ay1 - ay0:g} m square before the door "
          f"({area.area:g} m^2):")
    print(f"  max {density.density.max():.2f} /m^2 at t = {density.time[density.density.idxmax()]:.1f} s; "
          f"mean {crowded.density.mean():.2f} /m^2 over the {len(crowded)} frames with someone in it")

    # N-t and flow across the line in the doorway.
    nt, crossing_frames = pedpy.compute_n_t(traj_data=traj, measurement_line=line)
    n = int(nt.cumulative_pedestrians.max())
    t_first = crossing_frames.frame.min() / traj.frame_rate
    t_last = crossing_frames.frame.max() / traj.frame_rate
    width = float(np.hypot(x1 - x0, y1 - y0))
    mean_flow = (n - 1) / (t_last - t_first) if n > 1 else float("nan")
    print(f"flow across the line x = {x0:g}, {y0:g} <= y <= {y1:g} ({width:g} m wide):")
    print(f"  {n} of {data.id.nunique()} people crossed between t = {t_first:.1f} s and t = {t_last:.1f} s")
    print(f"  mean flow J = (N - 1) / (t_last - t_first) = {mean_flow:.3f} /s, "
          f"specific flow J / width = {mean_flow / width:.3f} /(m s)")

    # Individual speeds (central differences over +-frame_step frames, one-sided at the ends).
    speed = pedpy.compute_individual_speed(
        traj_data=traj,
        frame_step=args.frame_step,
        speed_calculation=pedpy.SpeedCalculation.BORDER_SINGLE_SIDED,
    )
    q = speed.speed.quantile([0.1, 0.5, 0.9]).to_numpy()
    print(f"individual speeds (+-{args.frame_step} frames): mean {speed.speed.mean():.3f} m/s, "
          f"10/50/90 % {q[0]:.3f} / {q[1]:.3f} / {q[2]:.3f} m/s, max {speed.speed.max():.3f} m/s")
    flow = pedpy.compute_flow(nt=nt, crossing_frames=crossing_frames, individual_speed=speed,
                              delta_frame=int(round(2 * traj.frame_rate)), frame_rate=traj.frame_rate)
    print(f"flow in 2 s windows (pedpy.compute_flow): mean {flow.flow.mean():.3f} /s, "
          f"min {flow.flow.min():.3f}, max {flow.flow.max():.3f}; "
          f"speed at the line {flow.mean_speed.mean():.3f} m/s")
    speed_in_area = pedpy.compute_mean_speed_per_frame(
        traj_data=traj, individual_speed=speed, measurement_area=area)
    print(f"mean speed in the square: {speed_in_area.speed.mean():.3f} m/s "
          f"(mean over {len(speed_in_area)} frames)")

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    pedpy.plot_measurement_setup(walkable_area=walkable_area, measurement_lines=[line],
                                 measurement_areas=[area], traj=traj, traj_color="0.45", traj_alpha=0.25,
                                 traj_width=0.4, ml_color="red", ma_color="orange",
                                 ma_alpha=0.3, axes=axes[0])
    axes[0].set_aspect("equal")
    axes[0].set_title("trajectories, door line (red), square (orange)")
    pedpy.plot_nt(nt=nt, axes=axes[1], title="people through the door")
    ts = np.array([t_first, t_last])
    axes[1].plot(ts, 1 + mean_flow * (ts - t_first), "k--", lw=1,
                 label=f"J = {mean_flow:.2f} /s")
    axes[1].legend(loc="upper left")
    axes[2].plot(density.time, density.density, color="tab:orange")
    axes[2].set_xlabel("t / s")
    axes[2].set_ylabel("classic density / (1/m²)")
    axes[2].set_title("density in the square before the door")
    fig.tight_layout()
    args.plot.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.plot, dpi=90)
    print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
