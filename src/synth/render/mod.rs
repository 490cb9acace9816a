//! The ray caster: per frame, the objects near the camera are culled and binned into
//! 16×16-pixel screen tiles by their projected bounds; each pixel's ray is intersected
//! analytically with the ground (road, raised sidewalks and kerb faces via Frenet
//! coordinates) and with the few primitives of its tile (boxes, cylinders, ellipsoids,
//! panels, and vehicles made of convex parts and wheels).
//!
//! The files, each using only those after it in this list: `view` ([`FrameView`]: a frame
//! ready for tracing, and the tracing), `place` (the frame's primitives and tile lists),
//! `lights` (the frame's lights and glows), `bounds` (screen rectangles, tile binning),
//! `prim` (primitives), `intersect_static` and `intersect_vehicle` (the ray tests of static
//! objects and of vehicles), `hit` (what a ray meets).

mod bounds;
mod hit;
mod intersect_static;
mod intersect_vehicle;
mod lights;
mod place;
mod prim;
mod view;

pub use bounds::TILE;
pub use hit::{GroundHint, Hit, WHEEL_PART};
pub use intersect_vehicle::intersect_vehicle;
pub use lights::{Light, LightsInReach, lamp_of};
pub use prim::PrimRef;
pub use view::FrameView;
