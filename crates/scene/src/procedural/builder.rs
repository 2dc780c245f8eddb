//! [`MeshBuilder`]: meshes assembled from boxes, frusta, ellipsoids and open shells, in the
//! asset frame of the furniture library (Z up, front +Y, metres).
//!
//! Texture coordinates are in metres of surface (one texture repeat per metre) and every
//! vertex has a normal, so built meshes need no post-processing. Faces are grouped by
//! scene-gen surface name ([`crate::materials::SURFACES`]) in order of first use, which keeps
//! the output a pure function of the calls made.

use std::f32::consts::{PI, TAU};

use glam::{Mat3, Mat4, Vec2, Vec3};

use crate::assets::{AssetMesh, AssetPart};

/// One surface's triangles.
#[derive(Clone, Debug)]
pub struct Part {
    pub surface: &'static str,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
}

/// A mesh under construction: parts in order of first use of their surface.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    pub parts: Vec<Part>,
}

impl MeshBuilder {
    pub fn part(&mut self, surface: &'static str) -> &mut Part {
        let index = match self.parts.iter().position(|p| p.surface == surface) {
            Some(i) => i,
            None => {
                self.parts.push(Part {
                    surface,
                    positions: Vec::new(),
                    normals: Vec::new(),
                    uvs: Vec::new(),
                    triangles: Vec::new(),
                });
                self.parts.len() - 1
            }
        };
        &mut self.parts[index]
    }

    /// A planar quad `p0 p1 p2 p3`, counter-clockwise seen from its outside; UVs are the
    /// local coordinates of the corners along the quad's own edges (metres).
    pub fn quad(&mut self, surface: &'static str, corners: [Vec3; 4], uv: [Vec2; 4]) {
        let normal = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize_or_zero();
        let part = self.part(surface);
        let base = part.positions.len() as u32;
        for (c, t) in corners.iter().zip(uv) {
            part.positions.push(*c);
            part.normals.push(normal);
            part.uvs.push(t);
        }
        part.triangles.push([base, base + 1, base + 2]);
        part.triangles.push([base, base + 2, base + 3]);
    }

    /// A box of `size` centred on the origin of the rigid frame `frame`.
    pub fn box_in(&mut self, surface: &'static str, frame: Mat4, size: Vec3) {
        let h = size * 0.5;
        // (normal axis, u axis, v axis) per face, each right-handed so u x v = normal.
        let faces = [
            (Vec3::X, Vec3::Y, Vec3::Z),
            (Vec3::NEG_X, Vec3::NEG_Y, Vec3::Z),
            (Vec3::Y, Vec3::NEG_X, Vec3::Z),
            (Vec3::NEG_Y, Vec3::X, Vec3::Z),
            (Vec3::Z, Vec3::X, Vec3::Y),
            (Vec3::NEG_Z, Vec3::X, Vec3::NEG_Y),
        ];
        for (n, u, v) in faces {
            let (hu, hv, hn) = (u.abs().dot(h), v.abs().dot(h), n.abs().dot(h));
            let local = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            let corners = local.map(|(su, sv)| frame.transform_point3(n * hn + u * (su * hu) + v * (sv * hv)));
            let uv = local.map(|(su, sv)| Vec2::new(su * hu + hu, sv * hv + hv));
            self.quad(surface, corners, uv);
        }
    }

    /// An axis-aligned box from `min` to `max`.
    pub fn cuboid(&mut self, surface: &'static str, min: Vec3, max: Vec3) {
        self.box_in(surface, Mat4::from_translation((min + max) * 0.5), max - min);
    }

    /// A frustum along the local +Z of `frame` from z = 0 (radius `r0`) to z = `height`
    /// (radius `r1`), with smooth side normals and optional flat caps.
    #[allow(clippy::too_many_arguments)]
    pub fn frustum(
        &mut self,
        side: &'static str,
        frame: Mat4,
        r0: f32,
        r1: f32,
        height: f32,
        segments: u32,
        bottom: Option<&'static str>,
        top: Option<&'static str>,
    ) {
        let slope = (r0 - r1) / height;
        let normal_matrix = Mat3::from_mat4(frame);
        {
            let part = self.part(side);
            let base = part.positions.len() as u32;
            let mean_r = (r0 + r1) * 0.5;
            let slant = Vec2::new(r0 - r1, height).length();
            for i in 0..=segments {
                let a = TAU * i as f32 / segments as f32;
                let (s, c) = a.sin_cos();
                let n = normal_matrix * Vec3::new(c, s, slope).normalize();
                for (r, z, v) in [(r0, 0.0, 0.0), (r1, height, slant)] {
                    part.positions.push(frame.transform_point3(Vec3::new(c * r, s * r, z)));
                    part.normals.push(n);
                    part.uvs.push(Vec2::new(a * mean_r, v));
                }
            }
            for i in 0..segments {
                let (a0, a1) = (base + 2 * i, base + 2 * i + 1);
                let (b0, b1) = (a0 + 2, a1 + 2);
                // A radius of zero (a cone's apex) collapses one triangle of the quad; leave
                // it out rather than emit a zero-area triangle.
                if r0 > 0.0 {
                    part.triangles.push([a0, b0, b1]);
                }
                if r1 > 0.0 {
                    part.triangles.push([a0, b1, a1]);
                }
            }
        }
        for (surface, r, z, up) in [(bottom, r0, 0.0, false), (top, r1, height, true)] {
            let Some(surface) = surface else { continue };
            let n = normal_matrix * if up { Vec3::Z } else { Vec3::NEG_Z };
            let part = self.part(surface);
            let centre = part.positions.len() as u32;
            part.positions.push(frame.transform_point3(Vec3::new(0.0, 0.0, z)));
            part.normals.push(n);
            part.uvs.push(Vec2::ZERO);
            for i in 0..segments {
                let a = TAU * i as f32 / segments as f32;
                let (s, c) = a.sin_cos();
                part.positions.push(frame.transform_point3(Vec3::new(c * r, s * r, z)));
                part.normals.push(n);
                part.uvs.push(Vec2::new(c * r, if up { s * r } else { -s * r }));
            }
            for i in 0..segments {
                let (p, q) = (centre + 1 + i, centre + 1 + (i + 1) % segments);
                part.triangles.push(if up { [centre, p, q] } else { [centre, q, p] });
            }
        }
    }

    /// A vertical cylinder standing on `base`.
    pub fn cylinder(&mut self, surface: &'static str, base: Vec3, r: f32, height: f32, segments: u32) {
        self.frustum(surface, Mat4::from_translation(base), r, r, height, segments, Some(surface), Some(surface));
    }

    /// An ellipsoid with semi-axes `radii` around `centre`: `segments` around, `rings` from
    /// pole to pole, smooth normals.
    pub fn ellipsoid(&mut self, surface: &'static str, centre: Vec3, radii: Vec3, segments: u32, rings: u32) {
        let part = self.part(surface);
        let base = part.positions.len() as u32;
        let mean_r = (radii.x + radii.y + radii.z) / 3.0;
        for j in 0..=rings {
            let polar = PI * j as f32 / rings as f32;
            let (sp, cp) = polar.sin_cos();
            for i in 0..=segments {
                let a = TAU * i as f32 / segments as f32;
                let (s, c) = a.sin_cos();
                let unit = Vec3::new(c * sp, s * sp, cp);
                part.positions.push(centre + unit * radii);
                part.normals.push((unit / radii).normalize());
                part.uvs.push(Vec2::new(a * mean_r, polar * mean_r));
            }
        }
        let row = segments + 1;
        for j in 0..rings {
            for i in 0..segments {
                let a = base + j * row + i;
                let (b, c, d) = (a + 1, a + row, a + row + 1);
                if j != 0 {
                    part.triangles.push([a, c, b]);
                }
                if j != rings - 1 {
                    part.triangles.push([b, c, d]);
                }
            }
        }
    }

    /// An open-topped box (a tub, a bowl): four walls of thickness `wall` and a bottom, so
    /// the cavity has real inner walls.
    pub fn open_box(&mut self, surface: &'static str, min: Vec3, max: Vec3, wall: f32, bottom: f32) {
        self.cuboid(surface, min, Vec3::new(max.x, max.y, min.z + bottom));
        let z0 = min.z + bottom;
        self.cuboid(surface, Vec3::new(min.x, min.y, z0), Vec3::new(max.x, min.y + wall, max.z));
        self.cuboid(surface, Vec3::new(min.x, max.y - wall, z0), Vec3::new(max.x, max.y, max.z));
        self.cuboid(surface, Vec3::new(min.x, min.y + wall, z0), Vec3::new(min.x + wall, max.y - wall, max.z));
        self.cuboid(surface, Vec3::new(max.x - wall, min.y + wall, z0), Vec3::new(max.x, max.y - wall, max.z));
    }

    /// Four square legs of side `t` under the corners of a rectangle.
    pub fn legs(&mut self, surface: &'static str, half: Vec2, t: f32, height: f32) {
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let c = Vec2::new(sx * (half.x - t * 0.5), sy * (half.y - t * 0.5));
            self.cuboid(
                surface,
                Vec3::new(c.x - t * 0.5, c.y - t * 0.5, 0.0),
                Vec3::new(c.x + t * 0.5, c.y + t * 0.5, height),
            );
        }
    }

    /// Moves the mesh so its footprint is centred on x = y = 0 and it rests on z = 0.
    pub fn recentre(&mut self) {
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in self.parts.iter().flat_map(|p| &p.positions) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let shift = Vec3::new(-(lo.x + hi.x) * 0.5, -(lo.y + hi.y) * 0.5, -lo.z);
        for p in self.parts.iter_mut().flat_map(|p| &mut p.positions) {
            *p += shift;
        }
    }

    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.triangles.len()).sum()
    }
}

impl MeshBuilder {
    /// An open shell (a bathtub, a basin's bowl): a superellipse outline `|x/a|^n + |y/b|^n = 1`
    /// of half extents `outer` extruded from `z0` up by `height`, with an inner wall `wall`
    /// inside it (outline exponent `inner_exponent`), a floor `bottom` thick and a flat rim.
    /// Exponent 2 is an ellipse; large exponents approach a rectangle.
    #[allow(clippy::too_many_arguments)]
    pub fn shell(
        &mut self,
        surface: &'static str,
        centre: Vec2,
        z0: f32,
        outer: Vec2,
        exponents: [f32; 2],
        height: f32,
        wall: f32,
        bottom: f32,
        segments: u32,
    ) {
        let outline = |half: Vec2, n: f32| -> Vec<(Vec2, Vec2)> {
            (0..segments)
                .map(|i| {
                    let (s, c) = (TAU * i as f32 / segments as f32).sin_cos();
                    let e = 2.0 / n;
                    let p = Vec2::new(c.signum() * c.abs().powf(e) * half.x, s.signum() * s.abs().powf(e) * half.y);
                    // The gradient of |x/a|^n + |y/b|^n is the outward normal.
                    let g = Vec2::new(
                        p.x.signum() * (p.x.abs() / half.x).powf(n - 1.0) / half.x,
                        p.y.signum() * (p.y.abs() / half.y).powf(n - 1.0) / half.y,
                    );
                    (centre + p, g.normalize_or(Vec2::new(c, s)))
                })
                .collect()
        };
        let inner_half = (outer - Vec2::splat(wall)).max(Vec2::splat(0.01));
        let out = outline(outer, exponents[0]);
        let inn = outline(inner_half, exponents[1]);
        let (z1, zf) = (z0 + height, z0 + bottom);
        let part = self.part(surface);
        let k = segments as usize;
        let push = |part: &mut Part, p: Vec3, n: Vec3, uv: Vec2| {
            part.positions.push(p);
            part.normals.push(n);
            part.uvs.push(uv);
            part.positions.len() as u32 - 1
        };
        // Walls: outer facing out, inner facing in; one quad per outline segment.
        for (ring, za, sign) in [(&out, z0, 1.0_f32), (&inn, zf, -1.0)] {
            let mut run = 0.0;
            let base = part.positions.len() as u32;
            for i in 0..=k {
                let (p, n) = ring[i % k];
                if i > 0 {
                    run += (p - ring[i - 1].0).length();
                }
                let normal = (n * sign).extend(0.0);
                push(part, p.extend(za), normal, Vec2::new(run, 0.0));
                push(part, p.extend(z1), normal, Vec2::new(run, z1 - za));
            }
            for i in 0..k as u32 {
                let (b0, t0, b1, t1) = (base + 2 * i, base + 2 * i + 1, base + 2 * i + 2, base + 2 * i + 3);
                if sign > 0.0 {
                    part.triangles.push([b0, b1, t1]);
                    part.triangles.push([b0, t1, t0]);
                } else {
                    part.triangles.push([b0, t1, b1]);
                    part.triangles.push([b0, t0, t1]);
                }
            }
        }
        // Rim (up), between the outlines.
        let base = part.positions.len() as u32;
        for i in 0..k {
            push(part, out[i].0.extend(z1), Vec3::Z, out[i].0);
            push(part, inn[i].0.extend(z1), Vec3::Z, inn[i].0);
        }
        for i in 0..k as u32 {
            let j = (i + 1) % k as u32;
            let (o0, i0, o1, i1) = (base + 2 * i, base + 2 * i + 1, base + 2 * j, base + 2 * j + 1);
            part.triangles.push([o0, o1, i1]);
            part.triangles.push([o0, i1, i0]);
        }
        // Underside (down) and the floor of the cavity (up): fans.
        for (ring, z, up) in [(&out, z0, false), (&inn, zf, true)] {
            let n = if up { Vec3::Z } else { Vec3::NEG_Z };
            let c = push(part, centre.extend(z), n, centre);
            for (p, _) in ring.iter() {
                push(part, p.extend(z), n, *p);
            }
            for i in 0..k as u32 {
                let (p, q) = (c + 1 + i, c + 1 + (i + 1) % k as u32);
                part.triangles.push(if up { [c, p, q] } else { [c, q, p] });
            }
        }
    }

    /// Bounding box of every position.
    #[must_use]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
        for p in self.parts.iter().flat_map(|p| &p.positions) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo, hi)
    }

    /// Scales every position by `factor` per axis (normals follow the inverse scale).
    pub fn scale(&mut self, factor: Vec3) {
        for part in &mut self.parts {
            part.positions.iter_mut().for_each(|p| *p *= factor);
            part.normals.iter_mut().for_each(|n| *n = (*n / factor).normalize_or_zero());
        }
    }

    /// The [`AssetMesh`] of the built triangles, texture v flipped as an OBJ file's would be
    /// on loading, so built and loaded meshes share one texture convention.
    #[must_use]
    pub fn into_asset_mesh(self) -> AssetMesh {
        let (min, max) = self.bounds();
        let parts = self
            .parts
            .into_iter()
            .map(|p| AssetPart {
                surface: p.surface.to_string(),
                positions: p.positions,
                normals: p.normals,
                uvs: p.uvs.into_iter().map(|t| Vec2::new(t.x, 1.0 - t.y)).collect(),
                indices: p.triangles.into_iter().flatten().collect(),
            })
            .collect();
        AssetMesh { parts, min, max }
    }
}

impl MeshBuilder {
    /// A flat-shaded octahedron with half extents `half` in the rigid frame `frame` (a leaf
    /// blade: pointed at both ends along z). Every face has its own vertices and its normal,
    /// so faces and normals agree under any scaling.
    pub fn diamond_in(&mut self, surface: &'static str, frame: Mat4, half: Vec3) {
        let axes = [Vec3::X * half.x, Vec3::Y * half.y, Vec3::Z * half.z];
        let part = self.part(surface);
        for sx in [-1.0_f32, 1.0] {
            for sy in [-1.0_f32, 1.0] {
                for sz in [-1.0_f32, 1.0] {
                    let (a, b, c) = (axes[0] * sx, axes[1] * sy, axes[2] * sz);
                    // Counter-clockwise seen from outside: the octant's sign parity decides.
                    let (b, c) = if sx * sy * sz > 0.0 { (b, c) } else { (c, b) };
                    let (pa, pb, pc) =
                        (frame.transform_point3(a), frame.transform_point3(b), frame.transform_point3(c));
                    let n = (pb - pa).cross(pc - pa).normalize_or_zero();
                    let base = part.positions.len() as u32;
                    for p in [pa, pb, pc] {
                        part.positions.push(p);
                        part.normals.push(n);
                        part.uvs.push(Vec2::new(p.x + p.y, p.z));
                    }
                    part.triangles.push([base, base + 1, base + 2]);
                }
            }
        }
    }
}
