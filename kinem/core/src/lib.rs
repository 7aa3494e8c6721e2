//! kinem's compiled core (issue 23): the constraint families of Nikravesh's
//! Chapter 4, the driving functions and outlines, the linear algebra, the
//! one Newton-Raphson loop, the one acceptance test and the march over
//! output instants. One fixed kernel serves every mechanism: a model is
//! handed over once as struct-of-arrays tables (kinem.model.compile) and
//! the core switches on the family type. Nothing is generated at run time.
// Numeric kernels index their arrays as the equations do (i, j, k), and test
// `!(x < limit)` on purpose: a NaN must fail every such test.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod accept;
pub mod columns;
pub mod decompose;
pub mod families;
pub mod functions;
pub mod lane_lu;
pub mod lanes;
pub mod lu;
pub mod march;
pub mod model;
pub mod newton;
pub mod order;
pub mod outline;
pub mod parts;
pub mod plan;
pub mod real;
pub mod sensitivity;
pub mod step;
pub mod table;
pub mod triangular;
pub mod variants;
pub mod watch;
pub mod wide;

#[cfg(feature = "python")]
mod py;
