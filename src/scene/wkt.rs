//! Geometry in WKT, as shapely and JuPedSim write it: `[room] wkt` (or `wkt_file`) is the
//! walkable area, a `POLYGON` whose holes are obstacles (or a `MULTIPOLYGON` of one polygon);
//! `exits_wkt` holds exits (`LINESTRING`s of two points), `obstacles_wkt` more polygon
//! obstacles. They are read into the scene's own items before anything is checked: the room's
//! `polygon`, `[[exits]]` after the file's, `[[obstacles]]` after the file's (the holes first),
//! so that every check and every error of those items applies to them, at `[room]`'s line.

use super::spec::{ExitSpec, ObstacleSpec, RoomSpec, SceneSpec};
use super::{Ctx, SceneError};
use std::path::Path;
use std::str::FromStr;
use toml::Spanned;
use wkt::Wkt;

/// A ring or line as points, the closing repeat of the first point dropped.
type Ring = Vec<[f64; 2]>;

/// The spec with `[room]`'s WKT keys read into the room's polygon, exits and obstacles;
/// `None` when the room has none. `base` is the directory `wkt_file` is relative to.
pub(super) fn expand(
    cx: &Ctx<'_>,
    spec: &SceneSpec,
    base: Option<&Path>,
) -> Result<Option<SceneSpec>, SceneError> {
    let room = spec.room.get_ref();
    if room.wkt.is_none()
        && room.wkt_file.is_none()
        && room.exits_wkt.is_none()
        && room.obstacles_wkt.is_none()
    {
        return Ok(None);
    }
    let line = cx.line_of(&spec.room);
    let span = spec.room.span();
    let err = |key: &str, m: String| cx.err(line, format!("[room] {key}"), m);
    let given = [
        room.rectangle.is_some(),
        room.polygon.is_some(),
        room.wkt.is_some(),
        room.wkt_file.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() > 1 {
        return Err(cx.err(
            line,
            "[room]",
            "give one of `rectangle`, `polygon`, `wkt` and `wkt_file`",
        ));
    }
    let mut out = spec.clone();
    let mut holes = Vec::new();
    let walkable = match (&room.wkt, &room.wkt_file) {
        (Some(text), _) => Some(("wkt", text.clone())),
        (None, Some(file)) => {
            let path = base.map_or_else(|| Path::new(file).to_path_buf(), |b| b.join(file));
            let text = std::fs::read_to_string(&path)
                .map_err(|e| err("wkt_file", format!("cannot read {}: {e}", path.display())))?;
            Some(("wkt_file", text))
        }
        (None, None) => None,
    };
    let mut new_room = RoomSpec {
        rectangle: room.rectangle,
        polygon: room.polygon.clone(),
        ..RoomSpec::default()
    };
    if let Some((key, text)) = walkable {
        let polygons = polygons(&parse(&text).map_err(|m| err(key, m))?)
            .map_err(|m| err(key, format!("{m}; the walkable area is a POLYGON (holes are obstacles) or a MULTIPOLYGON of one polygon")))?;
        let [rings] = <[Vec<Ring>; 1]>::try_from(polygons).map_err(|p| {
            err(
                key,
                format!(
                    "a MULTIPOLYGON of {} polygons: the walkable area must be one polygon; \
                     merge the parts into one (shapely: unary_union) and write that",
                    p.len()
                ),
            )
        })?;
        let mut rings = rings.into_iter();
        new_room.polygon = rings.next();
        holes.extend(rings);
    }
    out.room = Spanned::new(span.clone(), new_room);
    if let Some(text) = &room.exits_wkt {
        let lines = lines(&parse(text).map_err(|m| err("exits_wkt", m))?)
            .map_err(|m| err("exits_wkt", m))?;
        for (k, l) in lines.into_iter().enumerate() {
            let [from, to] = <[[f64; 2]; 2]>::try_from(l).map_err(|l| {
                err(
                    "exits_wkt",
                    format!(
                        "line {} has {} points: an exit is a LINESTRING of two points (give a \
                         MULTILINESTRING for several)",
                        k + 1,
                        l.len()
                    ),
                )
            })?;
            out.exits
                .push(Spanned::new(span.clone(), ExitSpec { from, to }));
        }
    }
    if let Some(text) = &room.obstacles_wkt {
        let polygons = polygons(&parse(text).map_err(|m| err("obstacles_wkt", m))?)
            .map_err(|m| err("obstacles_wkt", m))?;
        for rings in polygons {
            if rings.len() > 1 {
                return Err(err(
                    "obstacles_wkt",
                    "an obstacle with holes: give the polygons without holes (a hole in an \
                     obstacle cannot be reached)"
                        .into(),
                ));
            }
            holes.extend(rings);
        }
    }
    for ring in holes {
        out.obstacles.push(Spanned::new(
            span.clone(),
            ObstacleSpec {
                disk: None,
                segment: None,
                polygon: Some(ring),
                velocity: None,
                path: None,
            },
        ));
    }
    Ok(Some(out))
}

fn parse(text: &str) -> Result<Wkt<f64>, String> {
    let geometry = Wkt::<f64>::from_str(text.trim()).map_err(|e| format!("not valid WKT: {e}"))?;
    if !matches!(geometry.dimension(), wkt::types::Dimension::XY) {
        return Err(
            "coordinates with z or m: the scene is in the plane, give x y only".to_string(),
        );
    }
    Ok(geometry)
}

/// The points of a WKT line string, without the repeat of the first at the end of a ring.
fn points(l: &wkt::types::LineString<f64>, closed: bool) -> Ring {
    let mut p: Ring = l.coords().iter().map(|c| [c.x, c.y]).collect();
    if closed && p.len() > 1 && p.first() == p.last() {
        p.pop();
    }
    p
}

/// The polygons (each its rings, the exterior first) of a `POLYGON` or `MULTIPOLYGON`.
fn polygons(g: &Wkt<f64>) -> Result<Vec<Vec<Ring>>, String> {
    let rings = |p: &wkt::types::Polygon<f64>| -> Vec<Ring> {
        p.rings().iter().map(|r| points(r, true)).collect()
    };
    match g {
        Wkt::Polygon(p) if !p.rings().is_empty() => Ok(vec![rings(p)]),
        Wkt::MultiPolygon(m) if !m.polygons().is_empty() => {
            Ok(m.polygons().iter().map(rings).collect())
        }
        Wkt::Polygon(_) | Wkt::MultiPolygon(_) => Err("an EMPTY polygon".to_string()),
        other => Err(format!("a {} where polygons are expected", name(other))),
    }
}

/// The lines of a `LINESTRING` or `MULTILINESTRING`.
fn lines(g: &Wkt<f64>) -> Result<Vec<Ring>, String> {
    match g {
        Wkt::LineString(l) => Ok(vec![points(l, false)]),
        Wkt::MultiLineString(m) => Ok(m.line_strings().iter().map(|l| points(l, false)).collect()),
        other => Err(format!(
            "a {} where exits are expected: give a LINESTRING of two points, or a \
             MULTILINESTRING",
            name(other)
        )),
    }
}

fn name(g: &Wkt<f64>) -> &'static str {
    match g {
        Wkt::Point(_) => "POINT",
        Wkt::LineString(_) => "LINESTRING",
        Wkt::Polygon(_) => "POLYGON",
        Wkt::MultiPoint(_) => "MULTIPOINT",
        Wkt::MultiLineString(_) => "MULTILINESTRING",
        Wkt::MultiPolygon(_) => "MULTIPOLYGON",
        Wkt::GeometryCollection(_) => "GEOMETRYCOLLECTION",
    }
}
