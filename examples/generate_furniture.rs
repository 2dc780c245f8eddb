//! Writes the OBJ furniture library `examples/furniture_obj/<class>/<variant>.obj` with a
//! `<variant>.mtl` beside each: fixed low-poly meshes, one per variant, in the format of a
//! user's `--furniture` folder (the embedded library builds every object's shape with
//! `scene_gen::procedural` instead).
//!
//! ```text
//! cargo run --example generate_furniture            # rewrites examples/furniture_obj/*/*.obj|mtl
//! cargo run --example generate_furniture -- DIR     # writes into DIR instead
//! ```
//!
//! Every mesh is built from boxes, frusta and low-poly spheres, in the asset frame of the
//! library: Z up, resting on z = 0, centred on x = y = 0, front facing +Y, metres. Texture
//! coordinates are in metres of surface (one texture repeat per metre), normals are written for
//! every vertex, and faces are grouped by `usemtl <surface>` with surface names from
//! `scene_gen::materials::SURFACES`. The output is a pure function of this file (fixed decimal
//! formatting, no hash maps), so regenerating gives byte-identical files; `tests/placement.rs`
//! checks that against the committed library.

use std::f32::consts::FRAC_PI_2;
use std::fmt::Write as _;
use std::path::Path;

use glam::{Mat4, Vec2, Vec3};
use scene_gen::procedural::builder::MeshBuilder as Builder;

/// Fixed-precision number with no negative zero, so output bytes never depend on rounding
/// noise around 0.
fn num(x: f32) -> String {
    let s = format!("{x:.4}");
    if s == "-0.0000" { "0.0000".to_string() } else { s }
}

/// Diffuse colours for the `.mtl` files (linear-ish RGB, for viewers such as Blender only;
/// scene-gen takes its materials from the surface names).
fn diffuse(surface: &str) -> [f32; 3] {
    match surface {
        "wood" => [0.45, 0.28, 0.14],
        "fabric" => [0.35, 0.40, 0.55],
        "leather" => [0.30, 0.16, 0.08],
        "metal" => [0.70, 0.70, 0.72],
        "plastic" => [0.15, 0.15, 0.16],
        "ceramic" => [0.92, 0.92, 0.90],
        "screen" => [0.02, 0.02, 0.03],
        "leaf" => [0.15, 0.45, 0.12],
        "soil" => [0.25, 0.17, 0.10],
        "pot" => [0.70, 0.35, 0.20],
        "lampshade" => [0.95, 0.90, 0.78],
        "linen" => [0.92, 0.90, 0.86],
        _ => [0.6, 0.6, 0.6],
    }
}

fn obj_text(stem: &str, b: &Builder) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# scene-gen furniture mesh '{stem}', written by examples/generate_furniture.rs");
    let _ = writeln!(out, "# Z up, resting on z = 0, front facing +Y, metres; UVs in metres of surface");
    let _ = writeln!(out, "# {} triangles", b.triangle_count());
    let _ = writeln!(out, "mtllib {stem}.mtl");
    let _ = writeln!(out, "o {stem}");
    for p in b.parts.iter().flat_map(|p| &p.positions) {
        let _ = writeln!(out, "v {} {} {}", num(p.x), num(p.y), num(p.z));
    }
    for t in b.parts.iter().flat_map(|p| &p.uvs) {
        let _ = writeln!(out, "vt {} {}", num(t.x), num(t.y));
    }
    for n in b.parts.iter().flat_map(|p| &p.normals) {
        let n = n.normalize_or_zero();
        let _ = writeln!(out, "vn {} {} {}", num(n.x), num(n.y), num(n.z));
    }
    let mut offset = 1;
    for part in &b.parts {
        let _ = writeln!(out, "usemtl {}", part.surface);
        for t in &part.triangles {
            let [a, b, c] = t.map(|i| i + offset);
            let _ = writeln!(out, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
        }
        offset += part.positions.len() as u32;
    }
    out
}

fn mtl_text(stem: &str, b: &Builder) -> String {
    let mut out = format!("# materials of '{stem}'; names are scene-gen surface names\n");
    for part in &b.parts {
        let [r, g, bl] = diffuse(part.surface);
        let _ = write!(
            out,
            "\nnewmtl {}\nKd {} {} {}\nKs 0.0500 0.0500 0.0500\nNs 10.0000\nd 1.0000\nillum 2\n",
            part.surface,
            num(r),
            num(g),
            num(bl)
        );
    }
    out
}

// ---------------------------------------------------------------------------------------
// The classes. Back of every piece at -Y, front at +Y.

fn sofa(width: f32, seats: u32, surface: &'static str, chaise: bool) -> Builder {
    let mut b = Builder::default();
    let (d, arm, seat_z, back_z) = (0.9, 0.18, 0.44, 0.82);
    let (hx, hy) = (width * 0.5, d * 0.5);
    b.legs("wood", Vec2::new(hx, hy), 0.06, 0.08);
    b.cuboid(surface, Vec3::new(-hx, -hy, 0.08), Vec3::new(hx, hy, 0.3));
    b.cuboid(surface, Vec3::new(-hx, -hy, 0.3), Vec3::new(hx, -hy + 0.2, back_z));
    let front = if chaise { hy + 0.75 } else { hy };
    b.cuboid(surface, Vec3::new(-hx, -hy + 0.2, 0.3), Vec3::new(-hx + arm, hy, 0.62));
    b.cuboid(surface, Vec3::new(hx - arm, -hy + 0.2, 0.3), Vec3::new(hx, front, 0.62));
    let inner = width - 2.0 * arm;
    let w = inner / seats as f32;
    for i in 0..seats {
        let x0 = -hx + arm + w * i as f32 + 0.005;
        let x1 = x0 + w - 0.01;
        let y1 = if chaise && i == seats - 1 { front - 0.02 } else { hy - 0.02 };
        b.cuboid(surface, Vec3::new(x0, -hy + 0.2, 0.3), Vec3::new(x1, y1, seat_z));
        b.cuboid(surface, Vec3::new(x0, -hy + 0.2, seat_z), Vec3::new(x1, -hy + 0.36, back_z - 0.04));
    }
    if chaise {
        let x0 = hx - arm - w;
        b.cuboid(surface, Vec3::new(x0, hy, 0.08), Vec3::new(hx, front, 0.3));
        for x in [x0 + 0.01, hx - 0.07] {
            b.cuboid("wood", Vec3::new(x, front - 0.07, 0.0), Vec3::new(x + 0.06, front - 0.01, 0.08));
        }
    }
    b
}

fn bed(width: f32, length: f32, pillows: u32, footboard: bool) -> Builder {
    let mut b = Builder::default();
    let (hx, hy) = (width * 0.5, length * 0.5);
    b.legs("wood", Vec2::new(hx, hy), 0.08, 0.12);
    b.cuboid("wood", Vec3::new(-hx, -hy, 0.12), Vec3::new(hx, hy, 0.3));
    b.cuboid("linen", Vec3::new(-hx + 0.03, -hy + 0.03, 0.3), Vec3::new(hx - 0.03, hy - 0.03, 0.52));
    b.cuboid("fabric", Vec3::new(-hx + 0.02, hy - 0.55, 0.52), Vec3::new(hx - 0.02, hy - 0.15, 0.56));
    let w = (width - 0.2) / pillows as f32;
    for i in 0..pillows {
        let x0 = -hx + 0.1 + w * i as f32 + 0.03;
        b.cuboid("linen", Vec3::new(x0, -hy + 0.08, 0.52), Vec3::new(x0 + w - 0.06, -hy + 0.45, 0.64));
    }
    b.cuboid("wood", Vec3::new(-hx, -hy - 0.06, 0.0), Vec3::new(hx, -hy, 1.05));
    if footboard {
        b.cuboid("wood", Vec3::new(-hx, hy, 0.0), Vec3::new(hx, hy + 0.05, 0.6));
    }
    b
}

fn table_dining() -> Builder {
    let mut b = Builder::default();
    b.cuboid("wood", Vec3::new(-0.8, -0.45, 0.72), Vec3::new(0.8, 0.45, 0.76));
    b.legs("wood", Vec2::new(0.75, 0.4), 0.06, 0.72);
    b
}

fn table_round() -> Builder {
    let mut b = Builder::default();
    b.cylinder("wood", Vec3::new(0.0, 0.0, 0.71), 0.5, 0.04, 16);
    b.cylinder("wood", Vec3::new(0.0, 0.0, 0.05), 0.05, 0.66, 8);
    b.cylinder("metal", Vec3::ZERO, 0.28, 0.05, 12);
    b
}

fn table_desk() -> Builder {
    let mut b = Builder::default();
    b.cuboid("wood", Vec3::new(-0.7, -0.35, 0.72), Vec3::new(0.7, 0.35, 0.75));
    b.cuboid("wood", Vec3::new(-0.7, -0.33, 0.0), Vec3::new(-0.3, 0.33, 0.72));
    b.cuboid("wood", Vec3::new(0.66, -0.33, 0.0), Vec3::new(0.7, 0.33, 0.72));
    b.cuboid("wood", Vec3::new(-0.3, -0.35, 0.35), Vec3::new(0.66, -0.33, 0.72));
    for z in [0.15, 0.38, 0.61] {
        b.cuboid("metal", Vec3::new(-0.56, 0.33, z), Vec3::new(-0.44, 0.35, z + 0.02));
    }
    b
}

fn table_coffee() -> Builder {
    let mut b = Builder::default();
    b.cuboid("wood", Vec3::new(-0.55, -0.3, 0.38), Vec3::new(0.55, 0.3, 0.42));
    b.cuboid("wood", Vec3::new(-0.5, -0.25, 0.1), Vec3::new(0.5, 0.25, 0.12));
    b.legs("metal", Vec2::new(0.53, 0.28), 0.04, 0.38);
    b
}

fn chair_dining() -> Builder {
    let mut b = Builder::default();
    b.cuboid("wood", Vec3::new(-0.22, -0.22, 0.43), Vec3::new(0.22, 0.22, 0.47));
    for (x, y, top) in [(-0.2, -0.2, 0.9), (0.2, -0.2, 0.9), (0.2, 0.2, 0.43), (-0.2, 0.2, 0.43)] {
        b.cuboid("wood", Vec3::new(x - 0.02, y - 0.02, 0.0), Vec3::new(x + 0.02, y + 0.02, top));
    }
    b.cuboid("wood", Vec3::new(-0.18, -0.22, 0.66), Vec3::new(0.18, -0.19, 0.88));
    b.cuboid("wood", Vec3::new(-0.18, -0.22, 0.52), Vec3::new(0.18, -0.19, 0.56));
    b.cuboid("fabric", Vec3::new(-0.2, -0.18, 0.47), Vec3::new(0.2, 0.2, 0.5));
    b
}

fn chair_stool() -> Builder {
    let mut b = Builder::default();
    b.cylinder("leather", Vec3::new(0.0, 0.0, 0.62), 0.18, 0.05, 12);
    for (x, y) in [(-0.12, -0.12), (0.12, -0.12), (0.12, 0.12), (-0.12, 0.12)] {
        b.cuboid("metal", Vec3::new(x - 0.015, y - 0.015, 0.0), Vec3::new(x + 0.015, y + 0.015, 0.62));
    }
    b.cuboid("metal", Vec3::new(-0.12, 0.105, 0.24), Vec3::new(0.12, 0.135, 0.26));
    b.cuboid("metal", Vec3::new(-0.12, -0.135, 0.24), Vec3::new(0.12, -0.105, 0.26));
    b
}

fn chair_arm() -> Builder {
    let mut b = Builder::default();
    b.legs("wood", Vec2::new(0.3, 0.3), 0.05, 0.4);
    b.cuboid("leather", Vec3::new(-0.3, -0.3, 0.4), Vec3::new(0.3, 0.3, 0.5));
    let back = Mat4::from_translation(Vec3::new(0.0, -0.24, 0.72)) * Mat4::from_rotation_x(-0.15);
    b.box_in("leather", back, Vec3::new(0.6, 0.1, 0.5));
    for x in [-0.27, 0.27] {
        b.cuboid("leather", Vec3::new(x - 0.03, -0.2, 0.5), Vec3::new(x + 0.03, 0.28, 0.66));
    }
    b
}

fn bathtub(length: f32, width: f32, height: f32, wall: f32, feet: bool) -> Builder {
    let mut b = Builder::default();
    let (hx, hy) = (length * 0.5, width * 0.5);
    let z0 = if feet { 0.15 } else { 0.0 };
    b.open_box("ceramic", Vec3::new(-hx, -hy, z0), Vec3::new(hx, hy, z0 + height), wall, 0.06);
    if feet {
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            b.frustum(
                "metal",
                Mat4::from_translation(Vec3::new(sx * (hx - 0.15), sy * (hy - 0.1), 0.0)),
                0.05,
                0.03,
                z0,
                6,
                Some("metal"),
                None,
            );
        }
    }
    // Tap at the left end, on the rim.
    let tap = Vec3::new(-hx + wall * 0.5, 0.0, z0 + height);
    b.cylinder("metal", tap, 0.02, 0.12, 8);
    b.cuboid("metal", tap + Vec3::new(-0.01, -0.01, 0.1), tap + Vec3::new(0.12, 0.01, 0.12));
    b
}

fn basin_bowl(b: &mut Builder, centre: Vec3, size: Vec2, depth: f32) {
    let h = size * 0.5;
    b.open_box("ceramic", centre + Vec3::new(-h.x, -h.y, -depth), centre + Vec3::new(h.x, h.y, 0.0), 0.03, 0.02);
    let tap = centre + Vec3::new(0.0, -h.y + 0.015, 0.0);
    b.cylinder("metal", tap, 0.015, 0.14, 8);
    b.cuboid("metal", tap + Vec3::new(-0.01, 0.0, 0.12), tap + Vec3::new(0.01, 0.11, 0.14));
}

fn basin_pedestal() -> Builder {
    let mut b = Builder::default();
    b.frustum("ceramic", Mat4::IDENTITY, 0.12, 0.08, 0.7, 10, Some("ceramic"), Some("ceramic"));
    basin_bowl(&mut b, Vec3::new(0.0, 0.0, 0.86), Vec2::new(0.56, 0.44), 0.16);
    b
}

/// A vanity cabinet whose counter has one hole per bowl, each with a sunken bowl under it.
fn basin_vanity(width: f32, bowls: u32) -> Builder {
    let mut b = Builder::default();
    let (hx, hy, top) = (width * 0.5, 0.24, 0.84);
    b.cuboid("wood", Vec3::new(-hx + 0.01, -hy, 0.08), Vec3::new(hx - 0.01, hy - 0.02, top - 0.04));
    b.cuboid("wood", Vec3::new(-hx + 0.05, -hy + 0.04, 0.0), Vec3::new(hx - 0.05, hy - 0.06, 0.08));
    let (bw, bd) = (0.4, 0.3);
    let (y0, y1) = (-0.1, 0.2);
    let step = width / bowls as f32;
    let mut x = -hx;
    for i in 0..bowls {
        let cx = -hx + step * (i as f32 + 0.5);
        b.cuboid("ceramic", Vec3::new(x, -hy, top - 0.04), Vec3::new(cx - bw * 0.5, hy, top));
        b.cuboid("ceramic", Vec3::new(cx - bw * 0.5, -hy, top - 0.04), Vec3::new(cx + bw * 0.5, y0, top));
        b.cuboid("ceramic", Vec3::new(cx - bw * 0.5, y1, top - 0.04), Vec3::new(cx + bw * 0.5, hy, top));
        b.open_box(
            "ceramic",
            Vec3::new(cx - bw * 0.5, y0, top - 0.16),
            Vec3::new(cx + bw * 0.5, y1, top - 0.04),
            0.02,
            0.02,
        );
        let tap = Vec3::new(cx, -hy + 0.05, top);
        b.cylinder("metal", tap, 0.015, 0.14, 8);
        b.cuboid("metal", tap + Vec3::new(-0.01, 0.0, 0.12), tap + Vec3::new(0.01, 0.1, 0.14));
        b.cuboid("metal", Vec3::new(cx - 0.06, hy - 0.02, top - 0.14), Vec3::new(cx + 0.06, hy, top - 0.12));
        x = cx + bw * 0.5;
        let _ = bd;
    }
    b.cuboid("ceramic", Vec3::new(x, -hy, top - 0.04), Vec3::new(hx, hy, top));
    b
}

/// A screen panel of `size` (width, thickness, height) with its lower edge at `bottom`, the
/// display on its front (+Y) face.
fn screen_panel(b: &mut Builder, bottom: Vec3, size: Vec3) {
    let h = size * 0.5;
    b.cuboid("plastic", bottom + Vec3::new(-h.x, -h.y, 0.0), bottom + Vec3::new(h.x, h.y, size.z));
    b.cuboid(
        "screen",
        bottom + Vec3::new(-h.x + 0.015, h.y, 0.015),
        bottom + Vec3::new(h.x - 0.015, h.y + 0.004, size.z - 0.015),
    );
}

fn computer_tv() -> Builder {
    let mut b = Builder::default();
    b.cuboid("wood", Vec3::new(-0.7, -0.2, 0.06), Vec3::new(0.7, 0.2, 0.48));
    b.legs("metal", Vec2::new(0.68, 0.18), 0.04, 0.06);
    b.cuboid("plastic", Vec3::new(-0.6, 0.19, 0.12), Vec3::new(0.6, 0.2, 0.42));
    b.cuboid("metal", Vec3::new(-0.15, -0.12, 0.48), Vec3::new(0.15, 0.08, 0.5));
    b.cuboid("metal", Vec3::new(-0.04, -0.07, 0.5), Vec3::new(0.04, -0.03, 0.6));
    screen_panel(&mut b, Vec3::new(0.0, -0.03, 0.56), Vec3::new(1.12, 0.05, 0.66));
    b
}

fn computer_monitor() -> Builder {
    let mut b = Builder::default();
    b.cuboid("metal", Vec3::new(-0.11, -0.12, 0.0), Vec3::new(0.11, 0.06, 0.015));
    b.cuboid("metal", Vec3::new(-0.025, -0.09, 0.015), Vec3::new(0.025, -0.06, 0.2));
    screen_panel(&mut b, Vec3::new(0.0, -0.04, 0.09), Vec3::new(0.56, 0.04, 0.33));
    b
}

fn computer_laptop() -> Builder {
    let mut b = Builder::default();
    b.cuboid("metal", Vec3::new(-0.17, -0.12, 0.0), Vec3::new(0.17, 0.12, 0.018));
    b.cuboid("plastic", Vec3::new(-0.15, -0.1, 0.018), Vec3::new(0.15, 0.02, 0.021));
    // The lid, hinged at the back edge and opened 105 degrees (15 degrees past vertical).
    let hinge = Mat4::from_translation(Vec3::new(0.0, -0.12, 0.018)) * Mat4::from_rotation_x(0.26);
    b.box_in("metal", hinge * Mat4::from_translation(Vec3::new(0.0, -0.004, 0.115)), Vec3::new(0.34, 0.008, 0.23));
    b.box_in("screen", hinge * Mat4::from_translation(Vec3::new(0.0, 0.001, 0.115)), Vec3::new(0.3, 0.002, 0.19));
    b
}

fn pot(b: &mut Builder, r0: f32, r1: f32, height: f32) {
    b.frustum("pot", Mat4::IDENTITY, r0, r1, height, 10, Some("pot"), None);
    b.frustum(
        "soil",
        Mat4::from_translation(Vec3::new(0.0, 0.0, height - 0.03)),
        r1 - 0.01,
        r1 - 0.01,
        0.01,
        10,
        None,
        Some("soil"),
    );
}

fn plant_cones() -> Builder {
    let mut b = Builder::default();
    pot(&mut b, 0.13, 0.17, 0.3);
    b.cylinder("wood", Vec3::new(0.0, 0.0, 0.28), 0.02, 0.25, 6);
    for (z, r, h) in [(0.45, 0.3, 0.45), (0.7, 0.24, 0.4), (0.95, 0.16, 0.35)] {
        b.frustum("leaf", Mat4::from_translation(Vec3::new(0.0, 0.0, z)), r, 0.0, h, 9, Some("leaf"), None);
    }
    b
}

fn plant_bush() -> Builder {
    let mut b = Builder::default();
    pot(&mut b, 0.16, 0.2, 0.32);
    b.cylinder("wood", Vec3::new(0.0, 0.0, 0.3), 0.02, 0.15, 6);
    b.ellipsoid("leaf", Vec3::new(0.0, 0.0, 0.58), Vec3::new(0.22, 0.22, 0.2), 8, 5);
    for i in 0..4 {
        let a = FRAC_PI_2 * i as f32 + 0.4;
        let c = Vec3::new(a.cos() * 0.2, a.sin() * 0.2, 0.48 + 0.04 * i as f32);
        b.ellipsoid("leaf", c, Vec3::new(0.14, 0.14, 0.11), 6, 4);
    }
    b
}

fn plant_tall() -> Builder {
    let mut b = Builder::default();
    pot(&mut b, 0.15, 0.18, 0.36);
    b.cylinder("wood", Vec3::new(0.0, 0.0, 0.34), 0.025, 1.0, 6);
    for (i, z) in [0.75, 0.95, 1.15, 1.32].into_iter().enumerate() {
        let a = 2.4 * i as f32;
        let c = Vec3::new(a.cos() * 0.12, a.sin() * 0.12, z);
        b.ellipsoid("leaf", c, Vec3::new(0.2, 0.2, 0.09), 6, 4);
    }
    b.ellipsoid("leaf", Vec3::new(0.0, 0.0, 1.42), Vec3::new(0.16, 0.16, 0.1), 6, 4);
    b
}

fn lamp_floor() -> Builder {
    let mut b = Builder::default();
    b.cylinder("metal", Vec3::ZERO, 0.15, 0.03, 12);
    b.cylinder("metal", Vec3::new(0.0, 0.0, 0.03), 0.015, 1.3, 6);
    b.frustum(
        "lampshade",
        Mat4::from_translation(Vec3::new(0.0, 0.0, 1.22)),
        0.22,
        0.15,
        0.32,
        12,
        None,
        Some("lampshade"),
    );
    b
}

fn lamp_table() -> Builder {
    let mut b = Builder::default();
    b.cylinder("ceramic", Vec3::ZERO, 0.07, 0.02, 10);
    b.ellipsoid("ceramic", Vec3::new(0.0, 0.0, 0.13), Vec3::new(0.1, 0.1, 0.11), 10, 6);
    b.cylinder("metal", Vec3::new(0.0, 0.0, 0.23), 0.012, 0.12, 6);
    b.frustum(
        "lampshade",
        Mat4::from_translation(Vec3::new(0.0, 0.0, 0.3)),
        0.17,
        0.11,
        0.2,
        12,
        None,
        Some("lampshade"),
    );
    b
}

fn lamp_desk() -> Builder {
    let mut b = Builder::default();
    b.cylinder("metal", Vec3::new(0.0, -0.05, 0.0), 0.08, 0.025, 10);
    // Lower arm leaning back, upper arm reaching forward, head pointing down at the desk.
    let lower = Mat4::from_translation(Vec3::new(0.0, -0.05, 0.025)) * Mat4::from_rotation_x(0.35);
    b.frustum("metal", lower, 0.012, 0.012, 0.32, 6, None, Some("metal"));
    let elbow = lower.transform_point3(Vec3::new(0.0, 0.0, 0.32));
    let upper = Mat4::from_translation(elbow) * Mat4::from_rotation_x(-1.25);
    b.frustum("metal", upper, 0.012, 0.012, 0.3, 6, None, Some("metal"));
    let wrist = upper.transform_point3(Vec3::new(0.0, 0.0, 0.3));
    let head = Mat4::from_translation(wrist) * Mat4::from_rotation_x(-2.6);
    b.frustum("metal", head, 0.03, 0.09, 0.12, 10, Some("metal"), None);
    b.frustum(
        "lampshade",
        head * Mat4::from_translation(Vec3::new(0.0, 0.0, 0.11)),
        0.085,
        0.085,
        0.005,
        10,
        None,
        Some("lampshade"),
    );
    b
}

fn toy_ball() -> Builder {
    let mut b = Builder::default();
    b.ellipsoid("plastic", Vec3::new(0.0, 0.0, 0.11), Vec3::splat(0.11), 12, 8);
    b
}

fn toy_blocks() -> Builder {
    let mut b = Builder::default();
    let mut z = 0.0;
    for (size, yaw, surface) in [(0.1, 0.0, "wood"), (0.08, 0.35, "plastic"), (0.06, -0.3, "wood")] {
        let frame = Mat4::from_translation(Vec3::new(0.0, 0.0, z + size * 0.5)) * Mat4::from_rotation_z(yaw);
        b.box_in(surface, frame, Vec3::splat(size));
        z += size;
    }
    b.box_in(
        "plastic",
        Mat4::from_translation(Vec3::new(0.13, 0.02, 0.035)) * Mat4::from_rotation_z(0.6),
        Vec3::splat(0.07),
    );
    b
}

fn toy_teddy() -> Builder {
    let mut b = Builder::default();
    b.ellipsoid("fabric", Vec3::new(0.0, 0.0, 0.12), Vec3::new(0.09, 0.08, 0.12), 8, 5);
    b.ellipsoid("fabric", Vec3::new(0.0, 0.01, 0.3), Vec3::splat(0.08), 8, 5);
    for sx in [-1.0, 1.0] {
        b.ellipsoid("fabric", Vec3::new(sx * 0.06, 0.0, 0.37), Vec3::new(0.03, 0.015, 0.03), 6, 4);
        b.ellipsoid("fabric", Vec3::new(sx * 0.1, 0.03, 0.14), Vec3::new(0.035, 0.035, 0.07), 6, 4);
        b.ellipsoid("fabric", Vec3::new(sx * 0.055, 0.1, 0.04), Vec3::new(0.04, 0.07, 0.04), 6, 4);
        b.ellipsoid("plastic", Vec3::new(sx * 0.03, 0.08, 0.32), Vec3::splat(0.01), 4, 3);
    }
    b.ellipsoid("fabric", Vec3::new(0.0, 0.085, 0.28), Vec3::new(0.035, 0.03, 0.03), 6, 4);
    b
}

/// Every (class, variant) of the library in writing order.
fn library() -> Vec<(&'static str, &'static str, Builder)> {
    vec![
        ("sofa", "sofa_2seat", sofa(1.6, 2, "fabric", false)),
        ("sofa", "sofa_3seat", sofa(2.2, 3, "fabric", false)),
        ("sofa", "sofa_corner", sofa(2.4, 3, "fabric", true)),
        ("sofa", "sofa_armchair", sofa(0.95, 1, "leather", false)),
        ("bed", "bed_single", bed(0.9, 2.0, 1, false)),
        ("bed", "bed_double", bed(1.4, 2.0, 2, false)),
        ("bed", "bed_king", bed(1.8, 2.1, 2, true)),
        ("table", "table_dining", table_dining()),
        ("table", "table_round", table_round()),
        ("table", "table_desk", table_desk()),
        ("table", "table_coffee", table_coffee()),
        ("chair", "chair_dining", chair_dining()),
        ("chair", "chair_stool", chair_stool()),
        ("chair", "chair_arm", chair_arm()),
        ("bathtub", "bathtub_built_in", bathtub(1.7, 0.75, 0.56, 0.07, false)),
        ("bathtub", "bathtub_clawfoot", bathtub(1.6, 0.75, 0.6, 0.05, true)),
        ("bathtub", "bathtub_wide", bathtub(1.8, 0.9, 0.58, 0.12, false)),
        ("basin", "basin_pedestal", basin_pedestal()),
        ("basin", "basin_vanity", basin_vanity(0.7, 1)),
        ("basin", "basin_double", basin_vanity(1.3, 2)),
        ("computer", "computer_tv", computer_tv()),
        ("computer", "computer_monitor", computer_monitor()),
        ("computer", "computer_laptop", computer_laptop()),
        ("plant", "plant_cones", plant_cones()),
        ("plant", "plant_bush", plant_bush()),
        ("plant", "plant_tall", plant_tall()),
        ("lamp", "lamp_floor", lamp_floor()),
        ("lamp", "lamp_table", lamp_table()),
        ("lamp", "lamp_desk", lamp_desk()),
        ("toy", "toy_ball", toy_ball()),
        ("toy", "toy_blocks", toy_blocks()),
        ("toy", "toy_teddy", toy_teddy()),
    ]
}

/// The generated files: (path relative to the library root, contents), sorted by path.
pub fn generated_files() -> Vec<(String, String)> {
    let mut files = Vec::new();
    for (class, stem, mut builder) in library() {
        builder.recentre();
        files.push((format!("{class}/{stem}.obj"), obj_text(stem, &builder)));
        files.push((format!("{class}/{stem}.mtl"), mtl_text(stem, &builder)));
    }
    files.sort();
    files
}

/// Writes every generated file under `root`.
pub fn write_library(root: &Path) -> std::io::Result<()> {
    for (path, text) in generated_files() {
        let path = root.join(path);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)?;
        }
        std::fs::write(path, text)?;
    }
    Ok(())
}

#[allow(dead_code)]
fn main() -> std::io::Result<()> {
    let root = std::env::args()
        .nth(1)
        .unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/examples/furniture_obj").to_string());
    write_library(Path::new(&root))?;
    for (class, stem, builder) in library() {
        println!("{class}/{stem}: {} triangles", builder.triangle_count());
    }
    Ok(())
}
