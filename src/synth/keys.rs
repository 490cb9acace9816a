//! Object keys: the number every pixel's geometry is tagged with (sky, ground, backdrop, a
//! static object, a vehicle), which tracing, shading, flow and labels agree on.

/// Object key of the sky.
pub const KEY_SKY: u32 = 0;
/// Object key of the ground.
pub const KEY_GROUND: u32 = 1;
/// Object key of the distant backdrop (skyline, hills) at infinity.
pub const KEY_BACKDROP: u32 = 2;
/// Offset of static-object keys.
pub const KEY_STATIC: u32 = 16;
/// Bit marking vehicle keys (the rest is the vehicle index).
pub const KEY_VEHICLE: u32 = 0x8000_0000;
