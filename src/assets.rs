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

    /// The largest upward-facing flat area (a table top, a mattress): its height and the
    /// footprint rectangle of those faces, shrunk by 10 % on each side so round tops keep
    /// objects off their rim. `None` when the mesh has no horizontal upward faces.
    #[must_use]
    pub fn support_top(&self) -> Option<(f32, Vec2, Vec2)> {
        // Heights are bucketed to the centimetre; BTreeMap keeps the choice deterministic.
        let mut by_height: BTreeMap<i64, (f32, f32, Vec2, Vec2)> = BTreeMap::new();
        for part in &self.parts {
            for t in part.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| part.positions[t[k] as usize]);
                let n = (b - a).cross(c - a);
                let area = n.length() * 0.5;
                if area <= 1e-8 || n.z / (2.0 * area) < 0.99 {
                    continue;
                }
                let z = (a.z + b.z + c.z) / 3.0;
                let entry = by_height.entry((z * 100.0).round() as i64).or_insert((0.0, z, Vec2::MAX, Vec2::MIN));
                entry.0 += area;
                for p in [a, b, c] {
                    entry.2 = entry.2.min(p.truncate());
                    entry.3 = entry.3.max(p.truncate());
                }
            }
        }
        let mut best: Option<(f32, f32, Vec2, Vec2)> = None;
        for v in by_height.into_values() {
            if best.is_none_or(|b| v.0 > b.0 * 1.0001) {
                best = Some(v);
            }
        }
        best.map(|(_, z, lo, hi)| {
            let inset = (hi - lo) * 0.1;
            (z, lo + inset, hi - inset)
        })
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
