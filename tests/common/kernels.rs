//! Constraint kernels shared by the integration tests.

use sweeping::prelude::*;

/// `x ≥ 0` on one coordinate: affine and static.
pub struct Floor;

impl ConstraintKernel<1> for Floor {
    type Params = ();
    fn value<D: Scalar>(&self, _: &(), _t: D, z: [D; 1]) -> D {
        z[0]
    }
    fn is_time_dependent(&self) -> bool {
        false
    }
    fn is_affine(&self) -> bool {
        true
    }
}
