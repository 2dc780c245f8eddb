//! The irradiance volume on a generated house: its build time, what it adds to direct light,
//! and one view per room for the comparison with Mitsuba 3's path tracer
//! (examples/mitsuba/gi_compare.py).
//!
//! ```text
//! cargo run --release --example gi_views -- [--seed 7] [--res 160x120] [--out DIR] [--spacing M] [--rays N] [--bounces N] [--render-seed N]
//! ```
//!
//! Prints one JSON line per room: the view's mean luminance (nit, nominal light intensities)
//! by day and by night with direct light only and with the volume, and one line with the
//! volume's build (probes, rays, bounces, seconds). With `--out`, writes per room
//! `room_<r>.json` (the camera, in the form bench_render's `--camera-out` gives it) and
//! `room_<r>_<day|night>_<direct|volume>.f32` (linear RGB radiance per pixel, little-endian,
//! row-major from the top-left). Each camera stands 1.3 m high at the centre of its room,
//! pitched down 15 degrees, looking along the room's longer side; a 4 mm lens on a sensor
//! 5.6 mm wide (70 degrees across).

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use scene_gen::config::GeneratorConfig;
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::render::{Camera, Frame, RenderSettings, Renderer, VolumeSettings, luminance};
use scene_gen::scene::Scene;

type BoxResult<T> = Result<T, Box<dyn std::error::Error + Send + Sync>>;

struct Args {
    seed: u64,
    width: u32,
    height: u32,
    out: Option<PathBuf>,
    volume: VolumeSettings,
    /// Seed of the render's random streams (the volume's rays among them).
    render_seed: Option<u64>,
}

/// The value of `flag`, parsed, or a message naming the flag.
fn number<T: std::str::FromStr>(flag: &str, text: &str) -> Result<T, String> {
    text.parse().map_err(|_| format!("{flag} {text}: not a valid number"))
}

fn parse() -> Result<Args, String> {
    let mut args =
        Args { seed: 7, width: 160, height: 120, out: None, volume: VolumeSettings::DEFAULT, render_seed: None };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--seed" => args.seed = number(&flag, &value()?)?,
            "--res" => {
                let v = value()?;
                let (w, h) = v.split_once('x').ok_or_else(|| format!("--res {v}: expected WxH"))?;
                (args.width, args.height) = (number(&flag, w)?, number(&flag, h)?);
                if args.width == 0 || args.height == 0 {
                    return Err(format!("--res {v}: width and height must be at least 1"));
                }
            }
            "--out" => args.out = Some(value()?.into()),
            "--spacing" => {
                args.volume.spacing_m = number(&flag, &value()?)?;
                if args.volume.spacing_m.is_nan() || args.volume.spacing_m < 0.05 {
                    return Err(format!("--spacing {}: at least 0.05 m", args.volume.spacing_m));
                }
            }
            "--rays" => args.volume.rays = number(&flag, &value()?)?,
            "--bounces" => args.volume.max_bounces = number(&flag, &value()?)?,
            "--render-seed" => args.render_seed = Some(number(&flag, &value()?)?),
            _ => return Err(format!("unknown argument {flag}")),
        }
    }
    if args.volume.rays == 0 || args.volume.max_bounces == 0 {
        return Err("--rays and --bounces must be at least 1".into());
    }
    Ok(args)
}

/// The view of room `room`: its centre, 1.3 m high, along its longer side.
fn room_camera(scene: &Scene, room: usize, width: u32, height: u32) -> Camera {
    let r = &scene.rooms[room];
    let (lo, hi) = r.interior(scene.wall_thickness_m);
    let centre = (lo + hi) * 0.5;
    let size = hi - lo;
    let yaw_deg = if size.x >= size.y { 0.0 } else { 90.0 };
    // Back the camera off towards the near wall so it sees most of the room.
    let back = if size.x >= size.y { Vec3::new(-0.3 * size.x, 0.0, 0.0) } else { Vec3::new(0.0, -0.3 * size.y, 0.0) };
    Camera {
        width_px: width,
        height_px: height,
        pixel_pitch_um: 5600.0 / width as f32,
        focal_mm: 4.0,
        f_number: 2.0,
        position: centre.extend(1.3) + back,
        yaw_deg,
        pitch_deg: -15.0,
        vignetting: false,
    }
}

fn camera_json(scene: &Scene, room: usize, camera: &Camera) -> serde_json::Value {
    let (forward, right, up) = camera.basis();
    serde_json::json!({
        "seed": scene.seed,
        "room": room,
        "width": camera.width_px,
        "height": camera.height_px,
        "pixel_pitch_um": camera.pixel_pitch_um,
        "focal_mm": camera.focal_mm,
        "hfov_deg": camera.hfov_deg(),
        "vfov_deg": camera.vfov_deg(),
        "position": camera.position.to_array(),
        "forward": forward.to_array(),
        "right": right.to_array(),
        "up": up.to_array(),
    })
}

fn mean_luminance(radiance: &[[f32; 3]]) -> f64 {
    radiance.iter().map(|c| f64::from(luminance(Vec3::from(*c)))).sum::<f64>() / radiance.len().max(1) as f64
}

fn write_f32(path: &std::path::Path, radiance: &[[f32; 3]]) -> BoxResult<()> {
    let bytes: Vec<u8> = radiance.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes)?;
    Ok(())
}

fn main() -> BoxResult<()> {
    // Bad arguments: the message and exit status 2, before any work.
    let args = parse().unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let scene = generate(&GeneratorConfig { seed: args.seed, ..GeneratorConfig::default() }, &Library::embedded()?)?;
    // Four pixel samples, every light traced, so the views' own noise stays small.
    let standard = RenderSettings::standard();
    let seed = args.render_seed.unwrap_or(standard.seed);
    let base = RenderSettings { light_cull: 0.0, rect_samples_per_axis: 3, seed, ..standard };
    let direct = Renderer::new(&scene, RenderSettings { indirect_volume: None, ..base });
    let t0 = Instant::now();
    let lit = Renderer::new(&scene, RenderSettings { indirect_volume: Some(args.volume), ..base });
    let build_s = t0.elapsed().as_secs_f64();
    let volume = lit.volume().ok_or("no volume")?;
    println!(
        "{}",
        serde_json::json!({
            "seed": args.seed,
            "probes": volume.probe_count(),
            "probes_inside_solids": volume.invalid_probe_count(),
            "probe_rays": volume.probe_rays(),
            "bounces": volume.bounces(),
            "renderer_with_volume_s": build_s,
            "threads": rayon::current_num_threads(),
        })
    );
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out)?;
    }
    for room in 0..scene.rooms.len() {
        let camera = room_camera(&scene, room, args.width, args.height);
        let frames: [(&str, Frame); 2] = [("direct", direct.render(&camera)?), ("volume", lit.render(&camera)?)];
        let mut line = serde_json::json!({ "room": room, "type": scene.rooms[room].room_type });
        for (name, frame) in &frames {
            line[format!("day_{name}_nit")] = mean_luminance(&frame.day_nit).into();
            line[format!("night_{name}_nit")] = mean_luminance(&frame.night_nit).into();
            if let Some(out) = &args.out {
                write_f32(&out.join(format!("room_{room}_day_{name}.f32")), &frame.day_nit)?;
                write_f32(&out.join(format!("room_{room}_night_{name}.f32")), &frame.night_nit)?;
            }
        }
        if let Some(out) = &args.out {
            let json = serde_json::to_string_pretty(&camera_json(&scene, room, &camera))?;
            std::fs::write(out.join(format!("room_{room}.json")), json)?;
        }
        println!("{line}");
    }
    Ok(())
}
