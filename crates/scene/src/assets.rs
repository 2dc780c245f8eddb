//! OBJ assets of the furniture library, read with tobj into [`AssetMesh`] and turned into
//! [`scene::Mesh`](crate::scene::Mesh) once materials are known.
//!
//! The library may be embedded in the binary, so OBJ and MTL files are read from the bytes of
//! [`LibraryFile`]s (`tobj::load_obj_buf` with a material loader that looks the `mtllib` file
//! up among the OBJ's siblings), never from paths.
//!
//! Every loaded mesh is brought into the asset frame: Z up (Y-up files are rotated, see
//! [`UpAxis`]), footprint centred on x = y = 0 and resting on z = 0, so user meshes with any
//! origin work. Faces are grouped by material; the material name is the scene-gen surface
//! (see [`crate::materials::SURFACES`]) when it is one, otherwise the caller's fallback decides.
//! Missing normals are computed (area-weighted, smooth); missing UVs are projected from the
//! positions in metres.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3};

use crate::library::{LibraryError, LibraryFile};
use crate::scene::{Mesh, Primitive};

/// Which axis of an OBJ file points up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UpAxis {
    /// scene-gen's own convention: Z up, front +Y.
    #[default]
    Z,
    /// The glTF / most-DCC convention: Y up, front +Z. Read as `(x, y, z) -> (-x, z, y)`, a
    /// proper rotation that maps up to +Z and the front to +Y.
    Y,
}

/// The triangles of one surface of an asset, in the asset frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AssetPart {
    /// Scene-gen surface name the faces are drawn with.
    pub surface: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Texture coordinates in the glTF convention ((0, 0) top-left), in metres of surface.
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
}

/// A furniture mesh in the asset frame, before scaling and placement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AssetMesh {
    pub parts: Vec<AssetPart>,
    /// Bounding box; after loading `min.z = 0` and the footprint is centred on the origin.
    pub min: Vec3,
    pub max: Vec3,
}

/// Whether the source file carried its own normals and UVs (for library checks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AssetInfo {
    pub had_normals: bool,
    pub had_uvs: bool,
}

impl AssetMesh {
    /// Native size (x, y, z) of the bounding box.
    #[must_use]
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Every vertex position of every part.
    pub fn positions(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.parts.iter().flat_map(|p| p.positions.iter().copied())
    }

    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.indices.len() / 3).sum()
    }

    /// The top surface other objects may stand on (a table top, the uncovered part of a
    /// mattress): the flat upward-facing area seen from above that covers the most floor,
    /// as its height and the largest rectangle of it found by shrinking its bounding box.
    /// `None` when no flat upward face is visible from above.
    ///
    /// Seen from above matters: a bed frame's top is larger than its mattress but lies under
    /// it, and pillows cover part of the mattress.
    #[must_use]
    pub fn support_top(&self) -> Option<(f32, Vec2, Vec2)> {
        const N: usize = 40;
        let (lo, size) = (self.min.truncate(), (self.max - self.min).truncate());
        let step = size / N as f32;
        // Per cell: height of the highest geometry over the cell centre, and the centimetre
        // bucket of that height when it comes from a flat upward face.
        let mut top: Vec<(f32, Option<i64>)> = vec![(f32::MIN, None); N * N];
        for part in &self.parts {
            for t in part.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| part.positions[t[k] as usize]);
                let n = (b - a).cross(c - a);
                let projected = n.z * 0.5;
                if projected.abs() < 1e-10 {
                    continue;
                }
                let flat_up = n.z > 0.0 && n.z >= 0.99 * n.length();
                let z = if flat_up { (a.z + b.z + c.z) / 3.0 } else { a.z.max(b.z).max(c.z) };
                let bucket = flat_up.then(|| (z * 100.0).round() as i64);
                let (tmin, tmax) = (
                    a.truncate().min(b.truncate()).min(c.truncate()),
                    a.truncate().max(b.truncate()).max(c.truncate()),
                );
                let cell_range = |lo_v: f32, hi_v: f32, origin: f32, d: f32| {
                    let i0 = (((lo_v - origin) / d).floor().max(0.0) as usize).min(N - 1);
                    let i1 = (((hi_v - origin) / d).floor().max(0.0) as usize).min(N - 1);
                    i0..=i1
                };
                for j in cell_range(tmin.y, tmax.y, lo.y, step.y) {
                    for i in cell_range(tmin.x, tmax.x, lo.x, step.x) {
                        let p = lo + Vec2::new(i as f32 + 0.5, j as f32 + 0.5) * step;
                        let edge = |u: Vec3, v: Vec3| (v.x - u.x) * (p.y - u.y) - (v.y - u.y) * (p.x - u.x);
                        let (e0, e1, e2) = (edge(a, b), edge(b, c), edge(c, a));
                        let inside = (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
                        let cell = &mut top[i + j * N];
                        if inside && (z > cell.0 + 1e-4 || (flat_up && z > cell.0 - 1e-4 && cell.1.is_none())) {
                            *cell = (z, bucket);
                        }
                    }
                }
            }
        }
        let mut counts: BTreeMap<i64, usize> = BTreeMap::new();
        for b in top.iter().filter_map(|c| c.1) {
            *counts.entry(b).or_default() += 1;
        }
        // Most cells wins; among equals the higher surface (BTreeMap order, last max).
        let (&bucket, _) = counts.iter().max_by_key(|(b, n)| (**n, **b))?;
        // The largest rectangle of cells all on that surface: per row, column heights of the
        // run of surface cells ending there, then every histogram span (N is small).
        let mut heights = [0_usize; N];
        let mut best = (0, 0, 0, 0, 0); // (area, i0, i1, j0, j1)
        for j in 0..N {
            for (i, h) in heights.iter_mut().enumerate() {
                *h = if top[i + j * N].1 == Some(bucket) { *h + 1 } else { 0 };
            }
            for i0 in 0..N {
                let mut h = usize::MAX;
                for (i1, &column) in heights.iter().enumerate().skip(i0) {
                    h = h.min(column);
                    if h == 0 {
                        break;
                    }
                    let area = h * (i1 - i0 + 1);
                    if area > best.0 {
                        best = (area, i0, i1, j + 1 - h, j);
                    }
                }
            }
        }
        let (area, i0, i1, j0, j1) = best;
        if area == 0 {
            return None;
        }
        let z = top[i0 + j0 * N].0;
        Some((z, lo + Vec2::new(i0 as f32, j0 as f32) * step, lo + Vec2::new((i1 + 1) as f32, (j1 + 1) as f32) * step))
    }

    /// The [`Mesh`] of this asset; `material` maps each part's surface to an index into
    /// [`crate::scene::Geometry::materials`].
    pub fn to_mesh(&self, name: &str, mut material: impl FnMut(&str) -> usize) -> Mesh {
        Mesh {
            name: name.to_string(),
            primitives: self
                .parts
                .iter()
                .map(|p| Primitive {
                    positions: p.positions.clone(),
                    normals: p.normals.clone(),
                    uvs: p.uvs.clone(),
                    indices: p.indices.clone(),
                    material: material(&p.surface),
                })
                .collect(),
        }
    }
}

/// Whether an MTL file has a colour line (`Ka`, `Kd`, `Ks`, `Ke`) with fewer than three
/// numbers. tobj 4.0 panics on one (`parse_float3` unwraps a short array) where it returns an
/// error for any other malformed line, so such a file is treated as broken before it is parsed.
fn has_short_colour(mtl: &[u8]) -> bool {
    String::from_utf8_lossy(mtl).lines().any(|line| {
        let mut words = line.split_whitespace();
        matches!(words.next(), Some("Ka" | "Kd" | "Ks" | "Ke")) && words.take(3).count() < 3
    })
}

/// Reads `obj` (an OBJ file of a library) with its `mtllib` taken from `siblings`.
///
/// `surface_of` turns an OBJ material name (or `None` for faces without a known material)
/// into the surface they are drawn with; it is where the caller's fallback rule lives.
pub fn load_obj(
    obj: &LibraryFile,
    siblings: &[LibraryFile],
    up: UpAxis,
    mut surface_of: impl FnMut(Option<&str>) -> String,
) -> Result<(AssetMesh, AssetInfo), LibraryError> {
    let dir = obj.path.parent().map(std::path::Path::to_path_buf).unwrap_or_default();
    let options = tobj::LoadOptions { single_index: true, triangulate: true, ..tobj::LoadOptions::default() };
    let loader = |mtl: &std::path::Path| {
        let wanted = dir.join(mtl);
        match siblings.iter().find(|f| f.path == wanted) {
            Some(file) if has_short_colour(&file.bytes) => Err(tobj::LoadError::MaterialParseError),
            Some(file) => tobj::load_mtl_buf(&mut file.bytes.as_slice()),
            None => Err(tobj::LoadError::OpenFileFailed),
        }
    };
    let (models, materials) = tobj::load_obj_buf(&mut obj.bytes.as_slice(), &options, loader)
        .map_err(|e| LibraryError::new(&obj.path, None, format!("cannot read OBJ: {e}")))?;
    // A missing or broken .mtl leaves every face without a material: the fallback applies.
    let materials = materials.unwrap_or_default();

    let mut parts: Vec<AssetPart> = Vec::new();
    let mut info = AssetInfo { had_normals: true, had_uvs: true };
    for model in &models {
        let m = &model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let name = m.material_id.and_then(|i| materials.get(i)).map(|mat| mat.name.as_str());
        let surface = surface_of(name);
        let rotate = |v: [f32; 3]| match up {
            UpAxis::Z => Vec3::from(v),
            UpAxis::Y => Vec3::new(-v[0], v[2], v[1]),
        };
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(|p| rotate([p[0], p[1], p[2]])).collect();
        let has_normals = m.normals.len() == m.positions.len();
        let has_uvs = m.texcoords.len() / 2 == positions.len();
        info.had_normals &= has_normals;
        info.had_uvs &= has_uvs;
        let normals: Vec<Vec3> = if has_normals {
            m.normals.chunks_exact(3).map(|n| rotate([n[0], n[1], n[2]]).normalize_or(Vec3::Z)).collect()
        } else {
            smooth_normals(&positions, &m.indices)
        };
        // OBJ puts v = 0 at the bottom of a texture, glTF at the top.
        let uvs: Vec<Vec2> = if has_uvs {
            m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], 1.0 - t[1])).collect()
        } else {
            positions.iter().map(|p| Vec2::new(p.x + p.y, -p.z)).collect()
        };
        if let Some(bad) = m.indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(LibraryError::new(&obj.path, None, format!("face index {bad} out of range")));
        }
        let part = match parts.iter().position(|p| p.surface == surface) {
            Some(i) => &mut parts[i],
            None => {
                parts.push(AssetPart { surface, ..AssetPart::default() });
                parts.last_mut().expect("just pushed")
            }
        };
        let base = part.positions.len() as u32;
        part.positions.extend(positions);
        part.normals.extend(normals);
        part.uvs.extend(uvs);
        part.indices.extend(m.indices.iter().map(|i| i + base));
    }
    if parts.is_empty() {
        return Err(LibraryError::new(&obj.path, None, "the OBJ has no faces"));
    }
    let mut mesh = AssetMesh { parts, min: Vec3::ZERO, max: Vec3::ZERO };
    recentre(&mut mesh);
    if mesh.size().min_element() <= 0.0 || !mesh.size().is_finite() {
        return Err(LibraryError::new(&obj.path, None, "the OBJ is flat or not finite along some axis"));
    }
    Ok((mesh, info))
}

/// Moves the mesh so its footprint is centred on the origin and it rests on z = 0.
fn recentre(mesh: &mut AssetMesh) {
    let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
    for p in mesh.positions() {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let shift = Vec3::new(-(lo.x + hi.x) * 0.5, -(lo.y + hi.y) * 0.5, -lo.z);
    for p in mesh.parts.iter_mut().flat_map(|p| &mut p.positions) {
        *p += shift;
    }
    mesh.min = lo + shift;
    mesh.max = hi + shift;
}

/// Area-weighted vertex normals for meshes that came without any.
fn smooth_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
        if a.max(b).max(c) >= positions.len() {
            continue;
        }
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        for i in [a, b, c] {
            normals[i] += n;
        }
    }
    normals.into_iter().map(|n| n.normalize_or(Vec3::Z)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(path: &str, text: &str) -> LibraryFile {
        LibraryFile { path: path.into(), bytes: text.as_bytes().to_vec() }
    }

    const QUAD_Y_UP: &str =
        "mtllib q.mtl\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 0 0 3\nusemtl Wood_Old\nf 1 2 3\nusemtl wood\nf 1 3 4 5\n";

    #[test]
    fn y_up_is_rotated_recentred_and_materials_fall_back() {
        let obj = file("lib/x/q.obj", QUAD_Y_UP);
        let mtl = file("lib/x/q.mtl", "newmtl Wood_Old\nKd 1 0 0\nnewmtl wood\nKd 0 1 0\n");
        let (mesh, info) = load_obj(&obj, &[obj.clone(), mtl], UpAxis::Y, |name| match name {
            Some(n) if crate::materials::MaterialCatalog::is_surface(n) => n.to_string(),
            _ => "plastic".to_string(),
        })
        .unwrap();
        assert!(!info.had_normals && !info.had_uvs);
        let surfaces: Vec<_> = mesh.parts.iter().map(|p| p.surface.as_str()).collect();
        assert_eq!(surfaces, ["plastic", "wood"]);
        // Y-up extents (2, 1, 3) become Z-up (x 2, y 3, z 1).
        assert!((mesh.size() - Vec3::new(2.0, 3.0, 1.0)).length() < 1e-6, "{:?}", mesh.size());
        assert_eq!(mesh.min.z, 0.0);
        assert!((mesh.min.x + mesh.max.x).abs() < 1e-6 && (mesh.min.y + mesh.max.y).abs() < 1e-6);
        assert_eq!(mesh.triangle_count(), 1 + 2);
    }

    #[test]
    fn a_colour_with_two_numbers_breaks_the_mtl_not_the_process() {
        let obj = file("lib/x/q.obj", QUAD_Y_UP);
        let mtl = file("lib/x/q.mtl", "newmtl Wood_Old\nKd 1 0\nnewmtl wood\nKd 0 1 0\n");
        let (mesh, _) = load_obj(&obj, &[obj.clone(), mtl], UpAxis::Z, |n| {
            assert!(n.is_none(), "a broken MTL gives no material names, got {n:?}");
            "plastic".to_string()
        })
        .unwrap();
        assert_eq!(mesh.triangle_count(), 3);
    }

    #[test]
    fn missing_mtl_is_not_fatal_but_garbage_is() {
        let obj = file("lib/x/q.obj", QUAD_Y_UP);
        let (mesh, _) = load_obj(&obj, &[], UpAxis::Z, |n| {
            assert!(n.is_none());
            "metal".into()
        })
        .unwrap();
        assert_eq!(mesh.parts.len(), 1);
        let bad = file("lib/x/bad.obj", "v 0 0 0\nf 1 2 3\n");
        assert!(load_obj(&bad, &[], UpAxis::Z, |_| "metal".into()).is_err());
    }
}

#[cfg(test)]
mod support_tests {
    use super::*;

    /// A closed box as one part (12 outward triangles).
    fn boxed(parts: &mut AssetPart, min: Vec3, max: Vec3) {
        let c = |i: usize| Vec3::new([min.x, max.x][i & 1], [min.y, max.y][(i >> 1) & 1], [min.z, max.z][i >> 2]);
        let base = parts.positions.len() as u32;
        for i in 0..8 {
            parts.positions.push(c(i));
            parts.normals.push(Vec3::Z);
            parts.uvs.push(Vec2::ZERO);
        }
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        for [a, b, c, d] in quads {
            parts.indices.extend([a, b, c, a, c, d].map(|k| base + k));
        }
    }

    #[test]
    fn support_top_is_the_visible_mattress_not_the_frame_under_it() {
        let mut part = AssetPart { surface: "wood".into(), ..AssetPart::default() };
        boxed(&mut part, Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.3)); // frame
        boxed(&mut part, Vec3::new(-0.9, -0.9, 0.3), Vec3::new(0.9, 0.9, 0.5)); // mattress
        boxed(&mut part, Vec3::new(-0.8, -0.9, 0.5), Vec3::new(0.8, -0.5, 0.6)); // pillow
        let mesh = AssetMesh { parts: vec![part], min: Vec3::new(-1.0, -1.0, 0.0), max: Vec3::new(1.0, 1.0, 0.6) };
        let (z, lo, hi) = mesh.support_top().unwrap();
        assert!((z - 0.5).abs() < 1e-6, "top at {z}");
        assert!(lo.y >= -0.5 - 1e-6, "the rectangle reaches under the pillow: {lo} {hi}");
        assert!(lo.x >= -0.9 - 1e-6 && hi.x <= 0.9 + 1e-6 && hi.y <= 0.9 + 1e-6, "{lo} {hi}");
        assert!(hi.y - lo.y > 1.2 && hi.x - lo.x > 1.6, "{lo} {hi}");
    }
}
