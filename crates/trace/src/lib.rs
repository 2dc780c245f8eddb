//! Ray queries against triangles: geometry in, hits out. Nothing here knows about houses,
//! materials or lights; the renderer (scene-gen-render) lays its shading records out in the
//! order [`Bvh::build`] reports.
//!
//! * [`Bvh`] ([`bvh`]): obvhs builds a compressed-wide BVH, rays walk it with exact boxes and
//!   a watertight ray/triangle test, one ray at a time ([`Bvh::closest_hit`],
//!   [`Bvh::occluded`], [`Bvh::blocker`]).
//! * [`RayPacket`] ([`packet`]): up to [`packet::PACKET_RAYS`] coherent rays (a pixel tile,
//!   shadow rays to one light) walked together, with the same hits as one by one.
//! * [`lanes`]: structure-of-arrays helpers for code that works on a packet's rays together.
//! * `wide`, `quad`, `sse` (private): the tree as rays walk it, the four-ray triangle test and
//!   the SSE helpers under both.
//!
//! ```
//! use glam::Vec3;
//! use scene_gen_trace::{Bvh, test_util::quad};
//! let floor = quad(Vec3::ZERO, Vec3::X * 4.0, Vec3::Y * 4.0);
//! let (bvh, _) = Bvh::build(&floor, obvhs::BvhBuildParams::slow_build());
//! let hit = bvh.closest_hit(Vec3::new(0.5, 0.5, 1.2), -Vec3::Z, f32::INFINITY).expect("the floor");
//! assert!((hit.t - 1.2).abs() < 1e-6);
//! ```

pub mod bvh;
pub mod lanes;
pub mod packet;
mod quad;
#[cfg(target_arch = "x86_64")]
mod sse;
pub mod test_util;
mod wide;

pub use bvh::{Bvh, Hit};
pub use packet::RayPacket;
