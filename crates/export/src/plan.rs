//! `plan.png`: a top-down plan of a scene, north up.
//!
//! Rooms are filled by type and labelled, walls drawn at their thickness with door and window
//! openings, door leaves with their swing arcs as architects draw them, thresholds in gold,
//! furniture footprints coloured by class, with a legend and a scale bar. Drawn with plain rectangle fills and an 8x8 bitmap font so the picture needs no
//! font files and is identical on every machine.

use glam::Vec2;
use image::{Rgb, RgbImage};

use scene_gen_scene::scene::{DoorLeaf, ObjectClass, OpeningKind, Scene};

/// Pixels per metre of the plan.
const PX_PER_M: f32 = 40.0;
/// Margin around the house, pixels.
const MARGIN_PX: u32 = 40;
/// Width of the legend column, pixels.
const LEGEND_PX: u32 = 170;

const BACKGROUND: Rgb<u8> = Rgb([255, 255, 255]);
const WALL: Rgb<u8> = Rgb([40, 40, 40]);
const WINDOW: Rgb<u8> = Rgb([120, 190, 235]);
const GOLD: Rgb<u8> = Rgb([212, 175, 55]);
const TEXT: Rgb<u8> = Rgb([20, 20, 20]);
/// Furnishings (wardrobes, counters...): not detection targets, drawn in neutral grey.
const FURNISHING: Rgb<u8> = Rgb([176, 176, 176]);
/// A door's swing arc.
const SWING: Rgb<u8> = Rgb([150, 150, 150]);

/// Fill colour per class, in class-id order (a qualitative palette, Tableau 10).
const CLASS_RGB: [[u8; 3]; 10] = [
    [78, 121, 167],
    [242, 142, 43],
    [225, 87, 89],
    [118, 183, 178],
    [89, 161, 79],
    [237, 201, 72],
    [176, 122, 161],
    [156, 117, 95],
    [255, 157, 167],
    [186, 176, 172],
];

/// Pale fills for room types; unknown types get one by name hash.
const ROOM_RGB: [[u8; 3]; 6] =
    [[240, 234, 222], [226, 238, 244], [236, 244, 228], [246, 236, 236], [238, 236, 246], [244, 242, 226]];

/// Draws the plan of `scene` and returns it as PNG bytes.
#[must_use]
pub fn to_png(scene: &Scene) -> Vec<u8> {
    let image = draw(scene);
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut png,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Adaptive,
    )
    .write_image(image.as_raw(), image.width(), image.height(), image::ExtendedColorType::Rgb8)
    .expect("encoding a PNG into memory cannot fail");
    png
}

use image::ImageEncoder as _;

/// The plan as an image.
#[must_use]
pub fn draw(scene: &Scene) -> RgbImage {
    let e = scene.envelope;
    let width = 2 * MARGIN_PX + (e.width_m * PX_PER_M).ceil() as u32 + LEGEND_PX;
    let height = (2 * MARGIN_PX + (e.depth_m * PX_PER_M).ceil() as u32).max(MARGIN_PX + 14 * 14 + 60);
    let mut canvas = Canvas { image: RgbImage::from_pixel(width, height, BACKGROUND), depth_m: e.depth_m };

    for room in &scene.rooms {
        canvas.fill_world(room.min, room.max, room_color(&room.room_type));
    }
    for f in &scene.furnishings {
        canvas.fill_world(f.min.truncate(), f.max.truncate(), FURNISHING);
        canvas.outline_world(f.min.truncate(), f.max.truncate(), darker(FURNISHING));
    }
    for object in scene.objects.iter().filter(|o| o.on.is_none()).chain(scene.objects.iter().filter(|o| o.on.is_some()))
    {
        let [r, g, b] = CLASS_RGB[object.class as usize];
        canvas.fill_world(object.min.truncate(), object.max.truncate(), Rgb([r, g, b]));
        canvas.outline_world(object.min.truncate(), object.max.truncate(), darker(Rgb([r, g, b])));
    }
    draw_walls(&mut canvas, scene);
    for (door, leaf) in scene.doors.iter().filter_map(|d| d.leaf.map(|l| (d, l))) {
        draw_leaf(&mut canvas, &leaf, door.normal);
    }
    for threshold in &scene.thresholds {
        canvas.fill_world(threshold.min.truncate(), threshold.max.truncate(), GOLD);
    }
    for room in &scene.rooms {
        let label = scene_room_label(&room.room_type);
        let (x, y) = canvas.to_px(room.center());
        canvas.text_centered(x, y - 8, &label, 2, TEXT);
        let size = room.size_m();
        canvas.text_centered(x, y + 12, &format!("{:.1} x {:.1} m", size.x, size.y), 1, TEXT);
    }
    draw_scale_bar(&mut canvas, e.depth_m);
    draw_legend(&mut canvas, width - LEGEND_PX + 10);
    canvas.text(MARGIN_PX as i32, 12, &format!("scene-gen seed {}", scene.seed), 2, TEXT);
    canvas.image
}

fn draw_walls(canvas: &mut Canvas, scene: &Scene) {
    for wall in &scene.walls {
        let dir = (wall.b - wall.a).normalize_or_zero();
        let half = Vec2::new(-dir.y, dir.x) * (wall.thickness_m * 0.5);
        // Extend by half a thickness so corners close.
        let a = wall.a - dir * wall.thickness_m * 0.5;
        let b = wall.b + dir * wall.thickness_m * 0.5;
        canvas.fill_world((a - half).min(b + half), (a - half).max(b + half), WALL);
        for opening in &wall.openings {
            let c = wall.a + dir * opening.offset_m;
            let s = dir * opening.width_m * 0.5;
            let (lo, hi) = ((c - s - half).min(c + s + half), (c - s - half).max(c + s + half));
            match opening.kind {
                OpeningKind::Door => canvas.fill_world(lo, hi, BACKGROUND),
                OpeningKind::Window => canvas.fill_world(lo, hi, WINDOW),
            }
        }
    }
}

fn draw_scale_bar(canvas: &mut Canvas, depth_m: f32) {
    let y = (MARGIN_PX as f32 + depth_m * PX_PER_M) as i32 + 14;
    let x0 = MARGIN_PX as i32;
    for m in 0..5 {
        let color = if m % 2 == 0 { TEXT } else { BACKGROUND };
        let x = x0 + (m as f32 * PX_PER_M) as i32;
        canvas.fill_px(x, y, PX_PER_M as i32, 6, color);
    }
    canvas.outline_px(x0, y, (5.0 * PX_PER_M) as i32, 6, TEXT);
    canvas.text(x0, y + 10, "0", 1, TEXT);
    canvas.text(x0 + (5.0 * PX_PER_M) as i32 - 12, y + 10, "5 m", 1, TEXT);
}

fn draw_legend(canvas: &mut Canvas, x: u32) {
    let x = x as i32;
    let mut y = MARGIN_PX as i32;
    canvas.text(x, y, "Legend", 2, TEXT);
    y += 24;
    let entries = ObjectClass::ALL
        .iter()
        .map(|c| {
            (c.name(), {
                let [r, g, b] = CLASS_RGB[*c as usize];
                Rgb([r, g, b])
            })
        })
        .chain([("threshold", GOLD), ("furnishing", FURNISHING), ("window", WINDOW), ("wall", WALL)]);
    for (name, color) in entries {
        canvas.fill_px(x, y, 14, 10, color);
        canvas.outline_px(x, y, 14, 10, darker(color));
        canvas.text(x + 20, y + 1, name, 1, TEXT);
        y += 14;
    }
}

fn room_color(room_type: &str) -> Rgb<u8> {
    let index = match room_type {
        "bedroom" => 0,
        "bathroom" => 1,
        "living_room" => 2,
        "kitchen" => 3,
        "office" => 4,
        other => (scene_gen_core::rng::fnv1a64(other.as_bytes()) % ROOM_RGB.len() as u64) as usize,
    };
    Rgb(ROOM_RGB[index])
}

fn scene_room_label(room_type: &str) -> String {
    room_type.replace('_', " ")
}

fn darker(c: Rgb<u8>) -> Rgb<u8> {
    Rgb(c.0.map(|v| (u16::from(v) * 6 / 10) as u8))
}

/// A door leaf as a line from its hinge, and the arc its free edge swept from shut.
fn draw_leaf(canvas: &mut Canvas, leaf: &DoorLeaf, wall_normal: Vec2) {
    // Shut, the leaf lies along the wall: of the two ways to turn back by `open_deg`, the one
    // that ends square to the wall's normal.
    let back = |sign: f32| Vec2::from_angle(-sign * leaf.open_deg.to_radians()).rotate(leaf.direction);
    let sign = if back(1.0).dot(wall_normal).abs() <= back(-1.0).dot(wall_normal).abs() { 1.0 } else { -1.0 };
    let steps = (leaf.open_deg / 2.0).ceil() as usize;
    for i in 0..=steps {
        let turn = -sign * leaf.open_deg.to_radians() * i as f32 / steps as f32;
        let p = leaf.hinge + Vec2::from_angle(turn).rotate(leaf.direction) * leaf.width_m;
        canvas.fill_world(p, p, SWING);
    }
    let samples = (leaf.width_m * PX_PER_M).ceil() as usize * 2;
    for i in 0..=samples {
        let p = leaf.hinge + leaf.direction * (leaf.width_m * i as f32 / samples as f32);
        let (x, y) = canvas.to_px(p);
        canvas.fill_px(x - 1, y - 1, 2, 2, WALL);
    }
}

/// An image with the plan's world-to-pixel mapping.
struct Canvas {
    image: RgbImage,
    depth_m: f32,
}

impl Canvas {
    /// World (x east, y north) to pixel (column, row), north up.
    fn to_px(&self, p: Vec2) -> (i32, i32) {
        let x = MARGIN_PX as f32 + p.x * PX_PER_M;
        let y = MARGIN_PX as f32 + (self.depth_m - p.y) * PX_PER_M;
        (x.round() as i32, y.round() as i32)
    }

    fn fill_world(&mut self, min: Vec2, max: Vec2, color: Rgb<u8>) {
        let (x0, y1) = self.to_px(min);
        let (x1, y0) = self.to_px(max);
        self.fill_px(x0, y0, (x1 - x0).max(1), (y1 - y0).max(1), color);
    }

    fn outline_world(&mut self, min: Vec2, max: Vec2, color: Rgb<u8>) {
        let (x0, y1) = self.to_px(min);
        let (x1, y0) = self.to_px(max);
        self.outline_px(x0, y0, (x1 - x0).max(1), (y1 - y0).max(1), color);
    }

    fn fill_px(&mut self, x: i32, y: i32, w: i32, h: i32, color: Rgb<u8>) {
        let (iw, ih) = (self.image.width() as i32, self.image.height() as i32);
        for py in y.max(0)..(y + h).min(ih) {
            for px in x.max(0)..(x + w).min(iw) {
                self.image.put_pixel(px as u32, py as u32, color);
            }
        }
    }

    fn outline_px(&mut self, x: i32, y: i32, w: i32, h: i32, color: Rgb<u8>) {
        self.fill_px(x, y, w, 1, color);
        self.fill_px(x, y + h - 1, w, 1, color);
        self.fill_px(x, y, 1, h, color);
        self.fill_px(x + w - 1, y, 1, h, color);
    }

    /// Draws `text` with its top-left corner at (x, y), each font pixel `scale` pixels wide.
    fn text(&mut self, x: i32, y: i32, text: &str, scale: i32, color: Rgb<u8>) {
        use font8x8::UnicodeFonts as _;
        for (i, ch) in text.chars().enumerate() {
            let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else { continue };
            let gx = x + i as i32 * 8 * scale;
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        self.fill_px(gx + col * scale, y + row as i32 * scale, scale, scale, color);
                    }
                }
            }
        }
    }

    fn text_centered(&mut self, x: i32, y: i32, text: &str, scale: i32, color: Rgb<u8>) {
        let w = text.chars().count() as i32 * 8 * scale;
        self.text(x - w / 2, y - 4 * scale, text, scale, color);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene_gen_scene::config::GeneratorConfig;
    use scene_gen_scene::generate::generate;
    use scene_gen_scene::library::Library;

    #[test]
    fn plan_is_a_png_of_the_envelope_with_rooms_filled() {
        let scene = generate(&GeneratorConfig { seed: 3, ..GeneratorConfig::default() }, &Library::embedded().unwrap())
            .unwrap();
        let png = to_png(&scene);
        let image = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(image.width(), 2 * MARGIN_PX + 600 + LEGEND_PX);
        assert_eq!(image.height(), 2 * MARGIN_PX + 600);
        // A point inside the first room, away from labels, carries the room fill.
        let room = &scene.rooms[0];
        let canvas = Canvas { image: RgbImage::new(1, 1), depth_m: scene.envelope.depth_m };
        let (x, y) = canvas.to_px(room.min + Vec2::splat(0.6));
        let fill = room_color(&room.room_type);
        let found = image.get_pixel(x as u32, y as u32);
        let p = room.min + Vec2::splat(0.6);
        let inside = |min: glam::Vec3, max: glam::Vec3| p.cmpge(min.truncate()).all() && p.cmple(max.truncate()).all();
        let is_object = scene.objects.iter().any(|o| inside(o.min, o.max))
            || scene.furnishings.iter().any(|f| inside(f.min, f.max));
        assert!(is_object || *found == fill, "expected the room fill at ({x}, {y}), got {found:?}");
        // Every door leaf is drawn: the middle of each is wall-dark.
        let leaves: Vec<_> = scene.doors.iter().filter_map(|d| d.leaf).collect();
        assert!(!leaves.is_empty());
        for leaf in leaves {
            let (x, y) = canvas.to_px(leaf.hinge + leaf.direction * (0.5 * leaf.width_m));
            assert_eq!(*image.get_pixel(x as u32, y as u32), WALL, "leaf of room {} not drawn", leaf.room);
        }
    }
}
