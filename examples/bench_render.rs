//! Benchmark: the ray tracer on a generated house (seed 7), seen by an IMX174 camera (4 mm lens)
//! at a pose of the agent's walk.
//!
//! ```text
//! cargo run --release --example bench_render                 # the table below, best of 3
//! cargo run --release --example bench_render -- --case primary --res 640x480 --threads 1 \
//!     [--camera-out cam.json] [--depth-out depth.f32] [--repeats 3] # one case, one JSON line
//! ```
//!
//! The ray batches are traced in 8 x 8 pixel packets (`Accel::closest_hits`,
//! `Accel::occluded_packet`), as the renderer traces them; `--single` traces them one ray at a
//! time (`Accel::closest_hit`, `Accel::occluded`) instead, for the ratio between the two. Like
//! the renderer's tile loop, the batches run in a clone built for AVX2 and FMA where the CPU has
//! them (`SCENE_GEN_NO_SIMD=1`: the baseline build).
//!
//! Without `--case` it prints, for 640x480 and 1936x1216 on rayon pools of 1 and 2 threads, the
//! million rays per second of primary rays (closest hit through every pixel centre) and shadow
//! rays (any hit, from every primary hit to the night ceiling light nearest the camera), then
//! the wall time of one day + night frame pair at 1280x960 (`standard` settings, one trace for
//! both, both captures through the sensor model to DN).
//!
//! `--case` runs one workload and prints one JSON line with its times; examples/mitsuba/compare.py
//! runs it interleaved with Mitsuba 3 on the same view:
//! * `primary`, `shadow`: the ray batches above (`rays` = rays traced);
//! * `direct`: a real render (centre ray for labels + `--spp` jittered camera rays per pixel, one
//!   shadow ray per hit, textured Lambertian shading) of the house lit by that one point light,
//!   timed into the frame an untimed first render allocated; `--spp` must be a square;
//! * `pair`: the day + night pair at `--res` (light scaling measured once, outside the time);
//! * `speckle`: a `preview` day frame with light culling threshold `--cull` (default 0.1) and
//!   its speckle (see [`speckle`]): how noisy the culling roulette leaves a one-sample frame;
//! * `eval`: a frame with the evaluator's settings (`evaluate::eval_render_settings`), the
//!   irradiance volume traced beforehand (outside the time);
//! * `eval_direct`: the same frame without the volume (direct light only), its peer;
//! * `decoupled`: a `preview` frame (culling `--cull`, `--rect` x `--rect` rect samples) at full
//!   shading rate and with [`ShadingRate::Decoupled`] at `--stride` (default 2; with `--refine`,
//!   [`ShadingRate::Adaptive`] at that fine stride), each timed
//!   once, and the error of the decoupled frame against the full-rate one (see [`shading_error`]).
//!
//! Every resolution keeps the horizontal field of view of the full 1936 px sensor (the pixel
//! pitch is scaled), so all sizes show the same scene. `--camera-out` writes the camera (pose,
//! basis, fields of view), the light and the scene's triangle count as JSON; `--depth-out` the
//! ray distance of each pixel-centre ray (little-endian f32, row-major, +inf for a miss). A
//! harness of its own rather than criterion: the figures of interest are rays per second at
//! fixed sizes, and the comparison needs them per run.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use scene_gen::camera_spec::{CameraSpec, ResolvedCamera};
use scene_gen::capture::light_scales;
use scene_gen::config::GeneratorConfig;
use scene_gen::generate::generate;
use scene_gen::library::Library;
use scene_gen::radiometry::capture;
use scene_gen::render::accel::Accel;
use scene_gen::render::{Camera, Frame, RenderSettings, Renderer, ShadingRate};
use scene_gen::scene::{Light, LightGroup, LightKind, Scene};
use scene_gen::sensor::Catalog;
use scene_gen::simd::Dispatch;
use scene_gen::trace::packet::{PACKET_RAYS, RayPacket};
use scene_gen::trajectory::{self, TrajectoryParams};

type BoxResult<T> = Result<T, Box<dyn std::error::Error + Send + Sync>>;

/// The house: seed 7 of the default envelope, the scene `scene-gen --seed 7` writes.
const SEED: u64 = 7;
/// The sensor of the issue's 1936x1216 figures (Sony IMX174, 5.86 um pixels).
const SENSOR: &str = "IMX174";
/// Pose of the walk the camera stands at: inside the first room, looking along the walk
/// (chosen so most pixels see geometry at several depths, not a wall at arm's length).
const POSE_INDEX: usize = 6;
/// Runs per timed case unless `--repeats` says otherwise (more for profiling, where a pass of
/// tens of milliseconds would be lost in the setup).
static REPEATS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(3);

struct Setup {
    scene: Scene,
    resolved: ResolvedCamera,
    pose: trajectory::Pose,
    light: Light,
}

impl Setup {
    fn new() -> BoxResult<Setup> {
        let scene = generate(&GeneratorConfig { seed: SEED, ..GeneratorConfig::default() }, &Library::embedded()?)?;
        let resolved = CameraSpec::new(SENSOR).resolve(&Catalog::embedded())?;
        let walk =
            trajectory::plan(&scene, &TrajectoryParams { height_m: resolved.spec.height_m, ..Default::default() })?;
        let pose = walk.poses[POSE_INDEX.min(walk.poses.len() - 1)];
        let eye = resolved.camera_at(&pose).position;
        let light = scene
            .lights
            .iter()
            .filter(|l| l.kind == LightKind::Point && l.group == LightGroup::Night)
            .filter_map(|l| l.position.map(|p| (p.distance(eye), l)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, l)| l.clone())
            .ok_or("the house has no night point light")?;
        Ok(Setup { scene, resolved, pose, light })
    }

    /// The camera at `w x h`, keeping the full sensor's horizontal field of view.
    fn camera(&self, w: u32, h: u32) -> Camera {
        let full = self.resolved.camera_at(&self.pose);
        let pitch_um = full.pixel_pitch_um * full.width_px as f32 / w as f32;
        Camera { width_px: w, height_px: h, pixel_pitch_um: pitch_um, ..full }
    }

    /// The resolved camera binned to `w x h` (for the sensor model of a capture).
    fn resolved_at(&self, w: u32, h: u32) -> ResolvedCamera {
        let bin = f64::from(self.resolved.width_px) / f64::from(w);
        ResolvedCamera {
            width_px: w,
            height_px: h,
            bin_factor: bin,
            pixel_pitch_um: self.resolved.pixel_pitch_um * bin as f32,
            ..self.resolved.clone()
        }
    }

    fn light_position(&self) -> Vec3 {
        self.light.position.expect("filtered on position")
    }
}

/// CPU time of this process so far (all threads, user + system), seconds, from
/// `/proc/self/stat` (fields 14 and 15, in clock ticks of 1/100 s: Linux's USER_HZ); 0 where
/// that file cannot be read. On a machine shared with other work the wall time measures the
/// scheduler as much as the code; the CPU time does not.
fn process_cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // The command name (field 2) may hold spaces; the fields after it are plain numbers.
    let fields: Vec<&str> = stat.rsplit_once(')').map_or(vec![], |(_, rest)| rest.split_whitespace().collect());
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

thread_local! {
    /// CPU seconds per run of the last [`timed`] call on this thread.
    static LAST_CPU_S: std::cell::Cell<f64> = const { std::cell::Cell::new(0.0) };
}

/// Wall times of [`REPEATS`] runs of `run`, and what the last run returned; the mean CPU time
/// per run goes to [`LAST_CPU_S`].
fn timed<T>(mut run: impl FnMut() -> T) -> (Vec<f64>, T) {
    let mut times = Vec::new();
    let mut last = None;
    let cpu0 = process_cpu_s();
    let repeats = REPEATS.load(std::sync::atomic::Ordering::Relaxed);
    for _ in 0..repeats {
        let start = Instant::now();
        last = Some(run());
        times.push(start.elapsed().as_secs_f64());
    }
    LAST_CPU_S.with(|c| c.set((process_cpu_s() - cpu0) / repeats as f64));
    (times, last.expect("--repeats is at least 1"))
}

fn best(times: &[f64]) -> f64 {
    times.iter().copied().fold(f64::INFINITY, f64::min)
}

fn pixel_centre_directions(camera: &Camera) -> Vec<Vec3> {
    let basis = camera.basis();
    (0..camera.height_px)
        .flat_map(|y| (0..camera.width_px).map(move |x| (x, y)))
        .map(|(x, y)| camera.ray_direction_in(basis, x as f32 + 0.5, y as f32 + 0.5))
        .collect()
}

/// How the ray batches are traced: 8 x 8 pixel packets ([`RayPacket`], what the renderer does)
/// or one ray at a time (`--single`, for the ratio between the two).
#[derive(Clone, Copy, PartialEq)]
enum Traversal {
    Packet,
    Single,
}

/// Side of the square pixel tile whose rays form one packet (`PACKET_RAYS` = 64).
const TILE: usize = 8;

/// Pixel indices of the tiles of one band of `TILE` rows starting at row `y0`, tile by tile.
fn band_tiles(width: usize, height: usize, y0: usize) -> impl Iterator<Item = Vec<usize>> {
    (0..width.div_ceil(TILE)).map(move |tx| {
        (y0..(y0 + TILE).min(height))
            .flat_map(|y| (tx * TILE..(tx * TILE + TILE).min(width)).map(move |x| y * width + x))
            .collect()
    })
}

/// Whether the ray batches run in a clone of their loops built for AVX2 and FMA: where the
/// renderer's tile loop does (`scene_gen::simd`: this CPU has them and `SCENE_GEN_NO_SIMD` is not
/// set), so the batches measure the traversal code the renderer runs, not a baseline build of it
/// that no frame uses.
fn avx2_clone() -> bool {
    cfg!(target_arch = "x86_64") && Dispatch::current().supported() == Dispatch::Avx2Fma
}

/// Ray distance of every pixel-centre ray (+inf for a miss), on the current pool.
fn primary_pass(renderer: &Renderer<'_>, camera: &Camera, directions: &[Vec3], traversal: Traversal) -> Vec<f32> {
    let accel = renderer.accel();
    let origin = camera.position;
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    if traversal == Traversal::Single {
        return directions
            .par_chunks(1024)
            .flat_map_iter(|c| {
                c.iter().map(|d| accel.closest_hit(origin, *d, f32::INFINITY).map_or(f32::INFINITY, |h| h.t))
            })
            .collect();
    }
    let mut t = vec![f32::INFINITY; directions.len()];
    t.par_chunks_mut(w * TILE).enumerate().for_each(|(band, out)| {
        let tiles: Vec<Vec<usize>> = band_tiles(w, h, band * TILE).collect();
        let first_pixel = band * TILE * w;
        #[cfg(target_arch = "x86_64")]
        if avx2_clone() {
            // SAFETY: `avx2_clone` says this CPU runs AVX2 and FMA.
            return unsafe { primary_band_avx2(accel, origin, directions, &tiles, first_pixel, out) };
        }
        primary_band(accel, origin, directions, &tiles, first_pixel, out);
    });
    t
}

/// The closest-hit distance of the pixel-centre rays of one band's `tiles`, a packet per tile,
/// into `out` (which starts at pixel `first_pixel`).
#[inline(always)]
fn primary_band(
    accel: &Accel,
    origin: Vec3,
    directions: &[Vec3],
    tiles: &[Vec<usize>],
    first_pixel: usize,
    out: &mut [f32],
) {
    let mut packet = RayPacket::new();
    let mut hits = [None; PACKET_RAYS];
    for tile in tiles {
        packet.clear();
        for &i in tile {
            packet.push(origin, directions[i], f32::INFINITY);
        }
        accel.closest_hits(&mut packet, &mut hits);
        for (k, &i) in tile.iter().enumerate() {
            out[i - first_pixel] = hits[k].map_or(f32::INFINITY, |h| h.t);
        }
    }
}

/// [`primary_band`] compiled for AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn primary_band_avx2(
    accel: &Accel,
    origin: Vec3,
    directions: &[Vec3],
    tiles: &[Vec<usize>],
    first_pixel: usize,
    out: &mut [f32],
) {
    primary_band(accel, origin, directions, tiles, first_pixel, out);
}

/// A shadow ray: origin, unit direction, length.
type ShadowRay = (Vec3, Vec3, f32);

/// The shadow rays from every pixel whose centre ray hit (at distance `t`) to `light`, grouped
/// by 8 x 8 pixel tile. They start a little towards the light, as the shader's do.
fn shadow_rays(camera: &Camera, t: &[f32], light: Vec3) -> Vec<Vec<ShadowRay>> {
    let directions = pixel_centre_directions(camera);
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    (0..h.div_ceil(TILE))
        .flat_map(|band| band_tiles(w, h, band * TILE))
        .map(|tile| {
            tile.into_iter()
                .filter(|&i| t[i].is_finite())
                .map(|i| {
                    let to = light - (camera.position + directions[i] * t[i]);
                    let dist = to.length();
                    let dir = to / dist;
                    (light - to + dir * 1e-3, dir, dist - 2e-3)
                })
                .collect()
        })
        .collect()
}

/// Number of the `tiles`' shadow rays that are blocked, on the current pool.
fn shadow_pass(renderer: &Renderer<'_>, tiles: &[Vec<ShadowRay>], traversal: Traversal) -> usize {
    let accel = renderer.accel();
    tiles
        .par_chunks(32)
        .map(|chunk| {
            #[cfg(target_arch = "x86_64")]
            if avx2_clone() {
                // SAFETY: `avx2_clone` says this CPU runs AVX2 and FMA.
                return unsafe { blocked_in_tiles_avx2(accel, chunk, traversal) };
            }
            blocked_in_tiles(accel, chunk, traversal)
        })
        .sum()
}

/// [`blocked_in_tiles`] compiled for AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn blocked_in_tiles_avx2(accel: &Accel, tiles: &[Vec<ShadowRay>], traversal: Traversal) -> usize {
    blocked_in_tiles(accel, tiles, traversal)
}

/// Number of the shadow rays of `tiles` that are blocked, a packet per tile (or ray by ray).
#[inline(always)]
fn blocked_in_tiles(accel: &Accel, tiles: &[Vec<ShadowRay>], traversal: Traversal) -> usize {
    // Plain loops: an iterator adaptor's `fold` is compiled out of line, in the baseline build,
    // even when called from the AVX2 clone.
    let mut packet = RayPacket::new();
    let mut blocked = 0;
    for rays in tiles {
        match traversal {
            Traversal::Single => {
                for &(o, d, tmax) in rays {
                    blocked += usize::from(accel.occluded(o, d, tmax));
                }
            }
            Traversal::Packet => {
                packet.clear();
                for &(o, d, tmax) in rays {
                    packet.push(o, d, tmax);
                }
                blocked += accel.occluded_packet(&mut packet).count_ones() as usize;
            }
        }
    }
    blocked
}

/// FNV-1a of every buffer of a frame (radiance, depth, ids, normals, as little-endian bytes):
/// a change of any bit of the output changes it, so speed-ups that must keep the output
/// bit-identical can be checked against a build from before them.
fn frame_hash(frame: &Frame) -> String {
    let mut bytes = Vec::new();
    for c in frame.day_nit.iter().chain(&frame.night_nit).chain(&frame.normal) {
        bytes.extend(c.iter().flat_map(|v| v.to_le_bytes()));
    }
    bytes.extend(frame.depth_m.iter().flat_map(|v| v.to_le_bytes()));
    bytes.extend(frame.instance_id.iter().flat_map(|v| v.to_le_bytes()));
    bytes.extend(frame.class_id.iter().flat_map(|v| v.to_le_bytes()));
    format!("{:016x}", scene_gen::rng::fnv1a64(&bytes))
}

/// Wall time of one day + night pair: one render, then per group the scaled radiance through
/// the sensor model to DN. Returns (light scaling s, render s, capture s of both groups, CPU s
/// of render and captures, [`frame_hash`] of the render). Timed once: a pair takes seconds, and three would take minutes on
/// the loaded machine.
fn frame_pair(setup: &Setup, renderer: &Renderer<'_>, w: u32, h: u32) -> BoxResult<(f64, f64, f64, f64, String)> {
    let camera = setup.camera(w, h);
    let resolved = setup.resolved_at(w, h);
    let start = Instant::now();
    let scales = light_scales(renderer, SEED, &[LightGroup::Day, LightGroup::Night])?;
    let scale_s = start.elapsed().as_secs_f64();
    let cpu0 = process_cpu_s();
    let start = Instant::now();
    let frame = renderer.render(&camera)?;
    let render_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    for light in &scales {
        let radiance = light.radiance(&frame);
        let gain_db = match light.group {
            LightGroup::Day => resolved.spec.gain_day_db,
            LightGroup::Night => resolved.spec.gain_night_db,
        };
        let cap = capture(&resolved, &camera, &radiance, gain_db, SEED, 1);
        std::hint::black_box(cap.mean_variance());
    }
    let capture_s = start.elapsed().as_secs_f64();
    Ok((scale_s, render_s, capture_s, process_cpu_s() - cpu0, frame_hash(&frame)))
}

/// Error of radiance `test` against `reference`, per light group, over the luminance `Y` of
/// each pixel: (relative mean absolute error `sum |dY| / sum Y`, the same over the means of
/// 8 x 8 pixel blocks, where per-pixel sampling noise mostly averages out and what is left is
/// the bias of interpolation, relative error of the frame mean).
fn shading_error(reference: &Frame, test: &Frame) -> [(f64, f64, f64); 2] {
    let (w, h) = (reference.width as usize, reference.height as usize);
    [(&reference.day_nit, &test.day_nit), (&reference.night_nit, &test.night_nit)].map(|(a, b)| {
        let ya = Frame::luminance_nit(a);
        let yb = Frame::luminance_nit(b);
        let sum_a: f64 = ya.iter().map(|&v| f64::from(v)).sum();
        let sum_b: f64 = yb.iter().map(|&v| f64::from(v)).sum();
        let abs: f64 = ya.iter().zip(&yb).map(|(&p, &q)| f64::from((p - q).abs())).sum();
        let mut block_abs = 0.0;
        for by in (0..h).step_by(8) {
            for bx in (0..w).step_by(8) {
                let (mut sa, mut sb) = (0.0f64, 0.0f64);
                for y in by..(by + 8).min(h) {
                    for x in bx..(bx + 8).min(w) {
                        sa += f64::from(ya[y * w + x]);
                        sb += f64::from(yb[y * w + x]);
                    }
                }
                block_abs += (sa - sb).abs();
            }
        }
        let denom = sum_a.max(f64::MIN_POSITIVE);
        (abs / denom, block_abs / denom, (sum_b - sum_a) / denom)
    })
}

struct Args {
    case: Option<String>,
    width: u32,
    height: u32,
    threads: usize,
    spp: u32,
    camera_out: Option<PathBuf>,
    depth_out: Option<PathBuf>,
    cull: f32,
    rect: u32,
    stride: u32,
    refine: bool,
    traversal: Traversal,
}

/// `text`, the value of `flag`, as a number; the error names the flag and the value.
fn number<T: std::str::FromStr>(flag: &str, text: &str) -> BoxResult<T>
where
    T::Err: std::fmt::Display,
{
    text.parse().map_err(|e| format!("{flag} {text}: {e}").into())
}

/// The samples per axis of `spp` samples per pixel, when `spp` is a square of at least 1.
fn spp_axis(spp: u32) -> Option<u32> {
    let axis = f64::from(spp).sqrt().round() as u32;
    (axis > 0 && axis.checked_mul(axis) == Some(spp)).then_some(axis)
}

fn parse_args() -> BoxResult<Args> {
    let mut args = Args {
        case: None,
        width: 640,
        height: 480,
        threads: 1,
        spp: 1,
        camera_out: None,
        depth_out: None,
        cull: 0.1,
        rect: 1,
        stride: 2,
        refine: false,
        traversal: Traversal::Packet,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--case" => {
                let case = value()?;
                if !CASES.contains(&case.as_str()) {
                    return Err(format!("--case {case}: expected one of {}", CASES.join(", ")).into());
                }
                args.case = Some(case);
            }
            "--res" => {
                let v = value()?;
                let (w, h) = v.split_once('x').ok_or_else(|| format!("--res {v}: expected WxH"))?;
                (args.width, args.height) = (number(&flag, w)?, number(&flag, h)?);
                if args.width == 0 || args.height == 0 {
                    return Err(format!("--res {v}: width and height must be at least 1").into());
                }
            }
            "--threads" => args.threads = number(&flag, &value()?)?,
            "--spp" => {
                let spp: u32 = number(&flag, &value()?)?;
                if spp_axis(spp).is_none() {
                    return Err(format!("--spp {spp}: must be a square (1, 4, 9, ...)").into());
                }
                args.spp = spp;
            }
            "--camera-out" => args.camera_out = Some(value()?.into()),
            "--depth-out" => args.depth_out = Some(value()?.into()),
            "--cull" => args.cull = number(&flag, &value()?)?,
            "--rect" => args.rect = number(&flag, &value()?)?,
            "--stride" => args.stride = number(&flag, &value()?)?,
            "--refine" => args.refine = true,
            "--single" => args.traversal = Traversal::Single,
            "--repeats" => {
                let repeats: usize = number(&flag, &value()?)?;
                if repeats == 0 {
                    return Err("--repeats 0: must be at least 1".into());
                }
                REPEATS.store(repeats, std::sync::atomic::Ordering::Relaxed);
            }
            _ => return Err(format!("unknown argument {flag}").into()),
        }
    }
    Ok(args)
}

fn camera_json(setup: &Setup, camera: &Camera, triangles: usize) -> serde_json::Value {
    let (forward, right, up) = camera.basis();
    let light = setup.light_position();
    serde_json::json!({
        "seed": SEED,
        "sensor": SENSOR,
        "pose_index": POSE_INDEX,
        "width": camera.width_px,
        "height": camera.height_px,
        "pixel_pitch_um": camera.pixel_pitch_um,
        "focal_mm": camera.focal_mm,
        "hfov_deg": camera.hfov_deg(),
        "vfov_deg": camera.vfov_deg(),
        "position": camera.position.to_array(),
        "yaw_deg": camera.yaw_deg,
        "pitch_deg": camera.pitch_deg,
        "forward": forward.to_array(),
        "right": right.to_array(),
        "up": up.to_array(),
        "light_position": light.to_array(),
        "light_intensity_cd": setup.light.intensity,
        "triangles": triangles,
    })
}

fn run_case(setup: &Setup, args: &Args, case: &str) -> BoxResult<()> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(args.threads).build()?;
    let camera = setup.camera(args.width, args.height);
    let n = f64::from(args.width) * f64::from(args.height);
    let base = RenderSettings::standard();
    let renderer = Renderer::new(&setup.scene, base);
    if let Some(path) = &args.camera_out {
        std::fs::write(
            path,
            serde_json::to_string_pretty(&camera_json(setup, &camera, renderer.accel().triangle_count()))?,
        )?;
    }
    let directions = pixel_centre_directions(&camera);
    let traversal = args.traversal;
    let t = primary_pass(&renderer, &camera, &directions, Traversal::Packet);
    if let Some(path) = &args.depth_out {
        std::fs::write(path, t.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    }
    let (times, rays, extra) = match case {
        "primary" => {
            let (times, _) = timed(|| {
                pool.install(|| std::hint::black_box(primary_pass(&renderer, &camera, &directions, traversal)))
            });
            (times, directions.len(), serde_json::json!({}))
        }
        "shadow" => {
            let tiles = shadow_rays(&camera, &t, setup.light_position());
            let (times, blocked) = timed(|| pool.install(|| shadow_pass(&renderer, &tiles, traversal)));
            (times, tiles.iter().map(Vec::len).sum(), serde_json::json!({ "blocked": blocked }))
        }
        "direct" => {
            // `parse_args` refused any other count.
            let axis = spp_axis(args.spp).unwrap_or(1);
            let mut one_light = setup.scene.clone();
            one_light.lights = vec![setup.light.clone()];
            let settings = RenderSettings {
                samples_per_axis: axis,
                rect_samples_per_axis: 1,
                indirect_rays: 0,
                indirect_volume: None,
                specular: false,
                light_cull: 0.0,
                ..RenderSettings::preview()
            };
            let direct = Renderer::new(&one_light, settings);
            // A first render outside the timing allocates the frame; the timed ones render into
            // it (`render_into`), as the evaluator does along a walk. Mitsuba's timed calls
            // likewise follow a first call and reuse Dr.Jit's cached allocations; a fresh
            // 1936x1216 frame is 110 MB of pages for the kernel to fault in and zero.
            let mut frame = direct.render(&camera)?;
            let (times, rendered) = timed(|| pool.install(|| direct.render_into(&camera, &mut frame)));
            rendered?;
            let hash = frame_hash(&frame);
            let mean = frame.night_nit.iter().map(|c| f64::from(c[1])).sum::<f64>() / n;
            // Rays per pixel: the label ray, spp camera rays, a shadow ray per camera-ray hit.
            let hits = t.iter().filter(|t| t.is_finite()).count() as f64 / n;
            let rays = n * (1.0 + f64::from(args.spp) * (1.0 + hits));
            (times, rays as usize, serde_json::json!({ "spp": args.spp, "mean_green_nit": mean, "frame_fnv": hash }))
        }
        "pair" => {
            let (scale_s, render_s, capture_s, cpu_s, hash) =
                pool.install(|| frame_pair(setup, &renderer, args.width, args.height))?;
            LAST_CPU_S.with(|c| c.set(cpu_s));
            (
                vec![render_s + capture_s],
                0,
                serde_json::json!({
                    "light_scale_s": scale_s, "render_s": render_s, "capture_s": capture_s, "frame_fnv": hash,
                }),
            )
        }
        "speckle" => {
            let settings = RenderSettings { light_cull: args.cull, ..RenderSettings::preview() };
            let preview = Renderer::new(&setup.scene, settings);
            let (times, frame) = timed(|| pool.install(|| preview.render(&camera)));
            let frame = frame?;
            let (speckle, zero_median) = frame.day_speckle();
            let hash = frame_hash(&frame);
            (
                times,
                0,
                serde_json::json!({
                    "cull": args.cull, "speckle": speckle, "zero_median_px": zero_median, "frame_fnv": hash,
                }),
            )
        }
        "eval" | "eval_direct" => {
            let settings = scene_gen::evaluate::eval_render_settings();
            let settings = if case == "eval" { settings } else { RenderSettings { indirect_volume: None, ..settings } };
            let eval = Renderer::new(&setup.scene, settings);
            let (times, frame) = timed(|| pool.install(|| eval.render(&camera)));
            (times, 0, serde_json::json!({ "frame_fnv": frame_hash(&frame?) }))
        }
        "labels" => {
            let eval = Renderer::new(&setup.scene, scene_gen::evaluate::eval_render_settings());
            let (times, frame) = timed(|| pool.install(|| eval.render_labels(&camera)));
            (times, 0, serde_json::json!({ "frame_fnv": frame_hash(&frame?) }))
        }
        "ids" => {
            let eval = Renderer::new(&setup.scene, scene_gen::evaluate::eval_render_settings());
            let (times, ids) = timed(|| pool.install(|| eval.render_ids(&camera)));
            let ids = ids?;
            let bytes: Vec<u8> = ids.instance_id.iter().flat_map(|v| v.to_le_bytes()).collect();
            let hash = format!("{:016x}", scene_gen::rng::fnv1a64(&bytes));
            (times, 0, serde_json::json!({ "instance_fnv": hash }))
        }
        "decoupled" => {
            let full =
                RenderSettings { light_cull: args.cull, rect_samples_per_axis: args.rect, ..RenderSettings::preview() };
            let shading = if args.refine {
                ShadingRate::Adaptive { stride: args.stride, min_width_px: 0 }
            } else {
                ShadingRate::Decoupled { stride: args.stride, min_width_px: 0 }
            };
            let decoupled = RenderSettings { shading, ..full };
            let run = |settings: RenderSettings| -> BoxResult<(f64, f64, Frame)> {
                let renderer = Renderer::new(&setup.scene, settings);
                let cpu0 = process_cpu_s();
                let start = Instant::now();
                let frame = pool.install(|| renderer.render(&camera))?;
                Ok((start.elapsed().as_secs_f64(), process_cpu_s() - cpu0, frame))
            };
            let (full_s, full_cpu_s, reference) = run(full)?;
            let (dec_s, dec_cpu_s, frame) = run(decoupled)?;
            LAST_CPU_S.with(|c| c.set(dec_cpu_s));
            let [day, night] = shading_error(&reference, &frame);
            let err = |e: (f64, f64, f64)| serde_json::json!({ "pixel_mae": e.0, "block8_mae": e.1, "mean": e.2 });
            (
                vec![dec_s],
                0,
                serde_json::json!({
                    "cull": args.cull, "rect": args.rect, "stride": args.stride, "refine": args.refine,
                    "full_s": full_s, "full_cpu_s": full_cpu_s, "decoupled_s": dec_s, "decoupled_cpu_s": dec_cpu_s,
                    "labels_identical": reference.depth_m == frame.depth_m && reference.instance_id == frame.instance_id,
                    "frame_fnv": frame_hash(&frame), "full_frame_fnv": frame_hash(&reference),
                    "day_error": err(day), "night_error": err(night),
                }),
            )
        }
        _ => return Err(format!("--case {case}: expected one of {}", CASES.join(", ")).into()),
    };
    let b = best(&times);
    let mut out = serde_json::json!({
        "renderer": "scene-gen",
        "case": case,
        "traversal": if args.traversal == Traversal::Packet { "packet" } else { "single" },
        "width": args.width,
        "height": args.height,
        "threads": args.threads,
        "rays": rays,
        "times_s": times,
        "best_s": b,
        "mrays_per_s": rays as f64 / b / 1e6,
        "cpu_s": LAST_CPU_S.with(std::cell::Cell::get),
        "hit_fraction": t.iter().filter(|t| t.is_finite()).count() as f64 / n,
    });
    if let (Some(o), Some(e)) = (out.as_object_mut(), extra.as_object()) {
        o.extend(e.clone());
    }
    println!("{out}");
    Ok(())
}

/// The workloads of `--case`, checked before the house is built.
const CASES: [&str; 10] =
    ["primary", "shadow", "direct", "pair", "speckle", "eval", "eval_direct", "labels", "ids", "decoupled"];

fn main() -> BoxResult<()> {
    // Bad arguments: the message and exit status 2, before any work.
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let start = Instant::now();
    let setup = Setup::new()?;
    let generate_s = start.elapsed().as_secs_f64();
    if let Some(case) = &args.case {
        return run_case(&setup, &args, case);
    }
    let start = Instant::now();
    let renderer = Renderer::new(&setup.scene, RenderSettings::standard());
    let accel = renderer.accel();
    println!(
        "house seed {SEED}: {} triangles, generated in {:.0} ms, BVH and irradiance volume built in {:.0} ms; {SENSOR} at pose {POSE_INDEX} {:?}",
        accel.triangle_count(),
        generate_s * 1e3,
        start.elapsed().as_secs_f64() * 1e3,
        setup.pose.position
    );
    let light = setup.light_position();
    let traversal = args.traversal;
    println!(
        "| resolution | threads | primary Mrays/s (wall) | primary Mrays per CPU s | shadow Mrays/s (wall) | shadow Mrays per CPU s | hit fraction |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (w, h) in [(640u32, 480u32), (1936, 1216)] {
        let camera = setup.camera(w, h);
        let directions = pixel_centre_directions(&camera);
        let t = primary_pass(&renderer, &camera, &directions, Traversal::Packet);
        let tiles = shadow_rays(&camera, &t, light);
        let shadow_count: usize = tiles.iter().map(Vec::len).sum();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
            let (primary, _) = timed(|| {
                pool.install(|| std::hint::black_box(primary_pass(&renderer, &camera, &directions, traversal)))
            });
            let primary_cpu = LAST_CPU_S.with(std::cell::Cell::get);
            let (shadow, _) = timed(|| pool.install(|| shadow_pass(&renderer, &tiles, traversal)));
            let shadow_cpu = LAST_CPU_S.with(std::cell::Cell::get);
            let (np, ns) = (directions.len() as f64, shadow_count as f64);
            println!(
                "| {w}x{h} | {threads} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} |",
                np / best(&primary) / 1e6,
                np / primary_cpu / 1e6,
                ns / best(&shadow) / 1e6,
                ns / shadow_cpu / 1e6,
                ns / np
            );
        }
    }
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let (scale_s, render_s, capture_s, cpu_s, _) = pool.install(|| frame_pair(&setup, &renderer, 1280, 960))?;
        println!(
            "day + night pair 1280x960, standard, {threads} thread(s): {:.2} s wall, {cpu_s:.2} s CPU \
             (render {render_s:.2} s + capture {capture_s:.3} s); light scaling once per scene {scale_s:.2} s",
            render_s + capture_s
        );
    }
    Ok(())
}
