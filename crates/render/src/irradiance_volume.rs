//! Light that has bounced any number of times, from an irradiance volume computed once per
//! scene and shared by every view.
//!
//! A house is static and its light groups add linearly, so the indirect light it holds does
//! not depend on the camera: it is computed once, on a grid of probes in every room, and every
//! frame, candidate camera and scenario reads it. Each probe stores an *ambient cube*: the
//! irradiance on six faces looking along +x, -x, +y, -y, +z and -z, each the exact
//! cosine-weighted integral of what the probe's rays bring from that face's hemisphere; a
//! surface of normal `n` reads `n_x^2 E(+-x) + n_y^2 E(+-y) + n_z^2 E(+-z)` (McTaggart,
//! "Half-Life 2 / Valve Source shading", GDC 2004; Mitchell, McTaggart and Green, "Shading in
//! Valve's Source engine", SIGGRAPH 2006 course). Rooms, walls, floors and most furniture are
//! axis-aligned, and for those faces the cube is exact: a floor reads only the light from
//! above it, where order-2 spherical harmonics (Ramamoorthi and Hanrahan, SIGGRAPH 2001) ring
//! a few per cent of the floor's own light back onto it. A shading point blends the probes
//! of its room's grid around it trilinearly, as the irradiance volumes of Greger et al. ("The
//! irradiance volume", IEEE CG&A 1998) do, with two refinements of probe-based real-time
//! global illumination (Majercik et al., "Dynamic diffuse global illumination with
//! ray-traced irradiance fields", JCGT 2019): probes whose rays mostly hit back faces
//! (inside furniture) are left out, probes behind the surface weigh less, and a probe that
//! cannot see the shading point (behind a curtain, a cushion, a door leaf) drops out by the
//! same paper's Chebyshev test on how far its rays travelled in that direction. The distances
//! are kept on a 16x16 octahedral map (as Majercik et al.'s), each cell holding the distance
//! of one unshaded ray the probe traces through the cell's centre: a closest hit only, a
//! fraction of a shaded probe ray. The shaded rays are too few for the map: a cell averaging
//! them mixes a thin leaf with the room past its edge and lets the light through. Without the
//! test, a curtain panel or an open door leaf reads the probes on its other side, which see
//! that side lit by the window, and glows.
//!
//! How the probes learn the multi-bounce light: every probe casts [`VolumeSettings::rays`]
//! rays (a spherical Fibonacci set, randomly rotated per probe) and records what each hits:
//! its albedo and the direct light leaving it ([`LightSet::direct`] with shadow rays). Then
//! the volume is iterated: the radiance a ray brings back is the direct light leaving its hit
//! plus the hit's albedo times the irradiance the previous iteration's volume gives there. The
//! first pass holds light that bounced once, pass `k` light that bounced up to `k` times; the
//! loop stops when a pass changes the total by less than [`CONVERGED`] or after
//! [`VolumeSettings::max_bounces`]. Rays are traced once; the passes only re-read the volume.
//!
//! Rooms keep their own grids, so no probe is blended through a wall into the room next door;
//! light still passes through doors, because the probes' rays do. A point outside every
//! room's interior (in a doorway, in a wall) reads the nearest room's grid. What a probe's ray
//! meets on an emitter (a window) is direct light, counted by the direct term, not here.
//!
//! What is approximate: the volume is a smooth field sampled every [`VolumeSettings::spacing_m`],
//! so contact shadows of the indirect light (under a sofa, in a corner) are softer than real;
//! metals bounce only their diffuse part; on a tilted surface the cube's blend of three faces
//! is an approximation (exact for axis-aligned ones).

use std::f32::consts::PI;
use std::fmt::Write as _;
use std::hash::Hasher as _;
use std::sync::{Arc, Mutex, OnceLock};

use glam::{Quat, Vec2, Vec3};
use rayon::prelude::*;

use super::accel::Accel;
use super::lights::{Blockers, LightSet, ray_epsilon};
use super::shade::surface_response;
use super::{GroupRgb, Sampler, Strata};
use scene_gen_scene::scene::Scene;

/// A pass of the bounce iteration that changes the volume's total radiance by less than this
/// fraction ends it.
pub const CONVERGED: f32 = 1e-3;
/// A pass that changes the total by less than this fraction ends the iteration with the
/// geometric tail of the bounces left ([`IrradianceVolume::iterate`]): the tail's error is
/// a small part of a small part.
const TAIL_START: f32 = 0.03;
/// Largest ratio of one bounce to the one before that the tail trusts (a white room with no
/// openings approaches 1; the houses here sit near a half).
const MAX_BOUNCE_RATIO: f32 = 0.9;
/// Probes whose rays hit back faces more often than this stand inside a solid and are left
/// out of every blend (Majercik et al. use a quarter; some house meshes are open shells, so a
/// little more).
const MAX_BACKFACE_FRACTION: f32 = 0.3;
/// Most probes of the one grid of a scene without rooms.
const MAX_FREE_GRID_PROBES: usize = 8192;
/// How far the outer probes of a room stand in front of its walls, floor and ceiling, metres.
const PROBE_INSET_M: f32 = 0.02;
/// How far a shading point is moved along its normal before the blend, metres: enough to
/// leave the plane of the probes on its own wall.
const NORMAL_BIAS_M: f32 = 0.02;
/// Side of each probe's octahedral map of ray distances ([`depth_bin`]): 256 cells, about 7
/// degrees across.
const DEPTH_SIDE: usize = 16;
/// Direction cells of a probe's ray distances.
const DEPTH_BINS: usize = DEPTH_SIDE * DEPTH_SIDE;
/// Distance a ray that meets nothing counts as, metres (past any house).
const MISS_DISTANCE_M: f32 = 100.0;
/// Spread the visibility test allows a cell's distance: this much, plus [`DEPTH_SPREAD`] of
/// the distance, since the cell's ray runs up to about 5 degrees off the direction asked.
const DEPTH_SD_M: f32 = 0.02;
/// Spread per metre of distance ([`DEPTH_SD_M`]).
const DEPTH_SPREAD: f32 = 0.05;
/// Least visibility weight of a probe, so a point every probe's test rejects still blends.
const MIN_VISIBILITY: f32 = 1e-3;

/// The cell of direction `d` (unit) in a probe's octahedral map of ray distances: the sphere
/// folded onto the square `|u| + |v| <= 1` (upper half) and its corners (lower half), cut
/// into [`DEPTH_SIDE`]^2 cells.
#[inline]
fn depth_bin(d: Vec3) -> usize {
    let n = d / (d.x.abs() + d.y.abs() + d.z.abs()).max(f32::MIN_POSITIVE);
    let (u, v) =
        if n.z >= 0.0 { (n.x, n.y) } else { ((1.0 - n.y.abs()) * n.x.signum(), (1.0 - n.x.abs()) * n.y.signum()) };
    let cell = |x: f32| (((x + 1.0) * 0.5 * DEPTH_SIDE as f32) as usize).min(DEPTH_SIDE - 1);
    cell(u) + DEPTH_SIDE * cell(v)
}

/// The direction at the centre of cell `bin` of the octahedral map ([`depth_bin`] unfolded).
fn depth_bin_centre(bin: usize) -> Vec3 {
    let centre = |i: usize| (i as f32 + 0.5) / DEPTH_SIDE as f32 * 2.0 - 1.0;
    let (u, v) = (centre(bin % DEPTH_SIDE), centre(bin / DEPTH_SIDE));
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z >= 0.0 { (u, v) } else { ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum()) };
    Vec3::new(x, y, z).normalize()
}

/// Per cell of the octahedral map, how far the probe's ray through the cell's centre went.
type DepthMap = [f32; DEPTH_BINS];

/// [`DepthMap`] of a probe at `p`: one closest-hit ray through each cell's centre.
fn depth_map(accel: &Accel, p: Vec3) -> DepthMap {
    std::array::from_fn(|bin| {
        accel.closest_hit(p, depth_bin_centre(bin), f32::INFINITY).map_or(MISS_DISTANCE_M, |h| h.t)
    })
}

/// How much a probe whose distances are `depth` sees a point `offset` away (the point minus
/// the probe): 1 where the point is no farther than the probe's ray that way went, else
/// Chebyshev's bound on the chance that it is, cubed (Majercik et al. 2019), with the spread
/// the ray's direction allows ([`DEPTH_SD_M`], [`DEPTH_SPREAD`]).
#[inline]
fn visibility(depth: &DepthMap, offset: Vec3) -> f32 {
    let r = offset.length();
    if r <= 1e-6 {
        return 1.0;
    }
    let t = depth[depth_bin(offset / r)];
    if r <= t {
        return 1.0;
    }
    let sd = DEPTH_SD_M + DEPTH_SPREAD * t;
    let c = sd * sd / (sd * sd + (r - t) * (r - t));
    (c * c * c).max(MIN_VISIBILITY)
}

/// How the volume is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeSettings {
    /// Target distance between neighbouring probes, metres (each room gets a whole number of
    /// cells per axis, at least two).
    pub spacing_m: f32,
    /// Rays per probe.
    pub rays: u32,
    /// Most passes of the bounce iteration (bounces of the light).
    pub max_bounces: u32,
}

impl VolumeSettings {
    /// 0.6 m probes, 128 even rays each (and the caps round the lamps), up to 12 bounces:
    /// 4,266 probes and 1.36 M probe rays in house 7 (docs/BENCHMARKS.md, "Global
    /// illumination").
    pub const DEFAULT: VolumeSettings = VolumeSettings { spacing_m: 0.6, rays: 128, max_bounces: 12 };
}

impl Default for VolumeSettings {
    fn default() -> Self {
        VolumeSettings::DEFAULT
    }
}

/// Irradiance per channel on the six faces of an ambient cube: +x, -x, +y, -y, +z, -z.
type Cube = [Vec3; 6];
/// [`Cube`] per light group.
type GroupCube = [Cube; 2];

/// How much a ray arriving along `-d` (travelling along `d` away from the probe, i.e. coming
/// from direction `d`) adds to each face, per unit radiance and steradian: its cosine on the
/// faces that look towards it.
#[inline(always)]
fn cube_weights(d: Vec3) -> [f32; 6] {
    [d.x.max(0.0), (-d.x).max(0.0), d.y.max(0.0), (-d.y).max(0.0), d.z.max(0.0), (-d.z).max(0.0)]
}

/// One room's probes: a `dims` grid from `lo` in steps of `step`.
#[derive(Clone, Debug)]
struct ProbeGrid {
    /// The room's interior in the top view (a point inside belongs to this grid).
    xy_min: Vec2,
    xy_max: Vec2,
    lo: Vec3,
    step: Vec3,
    dims: [usize; 3],
    /// Index of the grid's first probe in the volume's lists.
    first: usize,
}

impl ProbeGrid {
    /// The grid over the box `lo..hi` whose outer probes stand [`PROBE_INSET_M`] in front of
    /// its faces, about `spacing_m` apart. Probes on the faces, not at cell centres: a probe
    /// inside the room is nearer a bright spot on the ceiling than the floor under it, and
    /// irradiance falls with distance, so probes set back from the walls and floor would
    /// overstate their light (by about a fifth on the floor below a ceiling light).
    fn over(lo: Vec3, hi: Vec3, spacing_m: f32, first: usize) -> ProbeGrid {
        let inset = Vec3::splat(PROBE_INSET_M).min((hi - lo).max(Vec3::ZERO) * 0.25);
        let (xy_min, xy_max) = (lo.truncate(), hi.truncate());
        let (lo, hi) = (lo + inset, hi - inset);
        let size = (hi - lo).max(Vec3::splat(1e-3));
        let count = |extent: f32| ((extent / spacing_m).round() as usize + 1).max(2);
        let dims = [count(size.x), count(size.y), count(size.z)];
        let step = size / Vec3::new((dims[0] - 1) as f32, (dims[1] - 1) as f32, (dims[2] - 1) as f32);
        ProbeGrid { xy_min, xy_max, lo, step, dims, first }
    }

    fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Position of the grid's `i`-th probe (x fastest, then y, then z).
    fn position(&self, i: usize) -> Vec3 {
        let (x, y, z) = (i % self.dims[0], (i / self.dims[0]) % self.dims[1], i / (self.dims[0] * self.dims[1]));
        self.lo + self.step * Vec3::new(x as f32, y as f32, z as f32)
    }

    /// Distance in the top view from `p` to the room's interior (0 inside).
    fn distance_xy(&self, p: Vec3) -> f32 {
        let q = p.truncate();
        (self.xy_min - q).max(q - self.xy_max).max(Vec2::ZERO).length()
    }
}

/// What one probe ray met: a lit surface, with what it sends back.
#[derive(Clone, Copy, Debug)]
struct Gather {
    /// What the ray adds to each face of the probe's cube per unit radiance
    /// ([`cube_weights`] times the solid angle it stands for).
    faces: [f32; 6],
    position: Vec3,
    normal: Vec3,
    /// Diffuse albedo over pi: radiance leaving per unit irradiance.
    albedo_over_pi: Vec3,
    /// Radiance leaving the hit towards the probe from direct light alone, per group.
    direct: GroupRgb,
    /// The grid the hit reads the volume from.
    grid: u32,
}

/// What a probe ray's hit needs in the bounce passes: [`Gather`] with the blend it reads.
#[derive(Clone, Copy, Debug)]
struct Bounce {
    faces: [f32; 6],
    albedo_over_pi: Vec3,
    direct: GroupRgb,
    blend: Blend,
}

/// How a surface reads the volume ([`IrradianceVolume::blend_in`]): up to eight probes with
/// weights summing to one (zero weight for a corner left out), and the three cube faces its
/// normal sees with their squared cosines (a surface of normal `n` reads
/// `n_x^2 E(+-x) + n_y^2 E(+-y) + n_z^2 E(+-z)`).
#[derive(Clone, Copy, Debug)]
struct Blend {
    probes: [u32; 8],
    weights: [f32; 8],
    faces: [u8; 3],
    face_weights: [f32; 3],
}

impl Blend {
    /// A blend of no probes for a surface facing `n`.
    fn facing(n: Vec3) -> Blend {
        let face = |axis: u8, v: f32| if v >= 0.0 { 2 * axis } else { 2 * axis + 1 };
        Blend {
            probes: [0; 8],
            weights: [0.0; 8],
            faces: [face(0, n.x), face(1, n.y), face(2, n.z)],
            face_weights: [n.x * n.x, n.y * n.y, n.z * n.z],
        }
    }

    /// The irradiance per group the blend gives from `cubes`.
    #[inline]
    fn read(&self, cubes: &[GroupCube]) -> GroupRgb {
        let mut e = [Vec3::ZERO; 2];
        for (&probe, &w) in self.probes.iter().zip(&self.weights) {
            if w == 0.0 {
                continue;
            }
            for (eg, cube) in e.iter_mut().zip(&cubes[probe as usize]) {
                *eg += self.seen(cube) * w;
            }
        }
        e.map(|v| v.max(Vec3::ZERO))
    }

    /// The irradiance one cube gives the surface.
    #[inline(always)]
    fn seen(&self, cube: &Cube) -> Vec3 {
        cube[usize::from(self.faces[0])] * self.face_weights[0]
            + cube[usize::from(self.faces[1])] * self.face_weights[1]
            + cube[usize::from(self.faces[2])] * self.face_weights[2]
    }
}

/// The multi-bounce indirect irradiance of a scene, per light group, at any point and normal.
#[derive(Clone, Debug)]
pub struct IrradianceVolume {
    grids: Vec<ProbeGrid>,
    /// Per probe (grid by grid, in each grid's order), whether it stands in free space.
    valid: Vec<bool>,
    /// Per probe, how far its rays went in each direction ([`visibility`]).
    depths: Vec<DepthMap>,
    /// Per probe, the irradiance of light that bounced at least once.
    cubes: Vec<GroupCube>,
    /// Passes the iteration ran (the bounces the light took at most).
    bounces: u32,
    /// Rays traced to build it (probe rays and their shadow rays are not told apart).
    probe_rays: u64,
}

impl IrradianceVolume {
    /// Traces and iterates the volume of `scene` (whose BVH is `accel` and lights `lights`, at
    /// their nominal intensities); random numbers from streams of `seed`. Probes run in
    /// parallel on the current rayon pool; the result is the same at any thread count.
    #[must_use]
    pub fn build(scene: &Scene, accel: &Accel, lights: &LightSet, settings: &VolumeSettings, seed: u64) -> Self {
        let grids = grids_of(scene, accel, settings.spacing_m.max(0.05));
        let positions: Vec<Vec3> =
            grids.iter().flat_map(|g| (0..g.len()).map(move |i| g.position(i))).collect::<Vec<_>>();
        let rays = settings.rays.max(1);
        let gathered: Vec<Probe> = positions
            .par_iter()
            .enumerate()
            .map(|(i, &p)| gather_probe(scene, accel, lights, &grids, p, rays, seed, i as u64))
            .collect();
        let valid = gathered.iter().map(|g| g.valid).collect();
        let depths = gathered.iter().map(|g| g.depth).collect();
        let probe_rays = gathered.iter().map(|g| u64::from(g.traced)).sum();
        let mut volume = IrradianceVolume {
            grids,
            valid,
            depths,
            cubes: vec![[[Vec3::ZERO; 6]; 2]; gathered.len()],
            bounces: 0,
            probe_rays,
        };
        // Which probes each hit reads depends on the probes' validity, known only now; the
        // passes then only re-weigh cubes.
        let bounces: Vec<Vec<Bounce>> = gathered
            .into_par_iter()
            .map(|probe| probe.gathers.into_iter().map(|g| volume.bounce_of(&g)).collect())
            .collect();
        volume.iterate(&bounces, settings.max_bounces);
        volume
    }

    /// What the bounce passes need of a probe ray's hit.
    fn bounce_of(&self, g: &Gather) -> Bounce {
        Bounce {
            faces: g.faces,
            albedo_over_pi: g.albedo_over_pi,
            direct: g.direct,
            blend: self.blend_in(g.grid as usize, g.position, g.normal),
        }
    }

    /// [`IrradianceVolume::build`], or the volume this process last built for the same scene
    /// and settings: every candidate camera an optimizer tries in a house reads the same
    /// light, and the evaluator prepares a renderer per candidate and house. The scene is
    /// recognised by a fingerprint of everything the build reads (geometry, materials,
    /// texels, lights, rooms); the last [`CACHED_VOLUMES`] volumes are kept.
    #[must_use]
    pub fn shared(scene: &Scene, accel: &Accel, lights: &LightSet, settings: &VolumeSettings, seed: u64) -> Arc<Self> {
        static CACHE: OnceLock<Mutex<Vec<Keyed>>> = OnceLock::new();
        let key = fingerprint(scene, settings, seed);
        let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
        if let Some((_, v)) =
            cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner).iter().find(|e| e.0 == key)
        {
            return Arc::clone(v);
        }
        let volume = Arc::new(IrradianceVolume::build(scene, accel, lights, settings, seed));
        let mut entries = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if !entries.iter().any(|e| e.0 == key) {
            if entries.len() >= CACHED_VOLUMES {
                entries.remove(0);
            }
            entries.push((key, Arc::clone(&volume)));
        }
        volume
    }

    /// Runs the bounce passes until a pass adds less than [`CONVERGED`] of the total, then
    /// adds the bounces not run as a geometric tail.
    ///
    /// Pass `k` adds the light of bounce `k`, and once the light has spread through the house
    /// each bounce is about the same fraction `r` of the one before (the mean albedo weighted
    /// by how much of each surface's view is other surfaces). The bounces after the last pass
    /// then sum to its increment times `r / (1 - r)`: Aitken's extrapolation of the series,
    /// with `r` measured from the last two increments and the tail given the last increment's
    /// shape. It stops the iteration some passes earlier for the same result.
    fn iterate(&mut self, bounces: &[Vec<Bounce>], max_bounces: u32) {
        let total = |r: &[GroupCube]| r.iter().flatten().flatten().map(|c| c.element_sum()).sum::<f32>();
        let mut last_increment = 0.0f32;
        for pass in 1..=max_bounces.max(1) {
            let next: Vec<GroupCube> = bounces.par_iter().map(|b| self.project(b)).collect();
            let previous = std::mem::replace(&mut self.cubes, next);
            self.bounces = pass;
            let now = total(&self.cubes);
            let increment = now - total(&previous);
            if now <= 0.0 {
                break;
            }
            if increment.abs() <= TAIL_START * now && pass >= 3 && last_increment > 0.0 {
                let ratio = (increment / last_increment).clamp(0.0, MAX_BOUNCE_RATIO);
                let tail = ratio / (1.0 - ratio);
                for (r, p) in self.cubes.iter_mut().zip(&previous) {
                    for (rg, pg) in r.iter_mut().zip(p) {
                        for (c, q) in rg.iter_mut().zip(pg) {
                            *c += (*c - *q) * tail;
                        }
                    }
                }
                break;
            }
            if increment.abs() <= CONVERGED * now {
                break;
            }
            last_increment = increment;
        }
    }

    /// One probe's cube from its rays, the hits read from the current volume.
    fn project(&self, bounces: &[Bounce]) -> GroupCube {
        let mut cube = [[Vec3::ZERO; 6]; 2];
        for g in bounces {
            let e = g.blend.read(&self.cubes);
            for group in 0..2 {
                let l = g.direct[group] + g.albedo_over_pi * e[group];
                for (c, w) in cube[group].iter_mut().zip(g.faces) {
                    *c += l * w;
                }
            }
        }
        cube
    }

    /// Indirect irradiance per group (lux per channel) on a surface at `point` facing `normal`.
    #[must_use]
    #[inline]
    pub fn irradiance(&self, point: Vec3, normal: Vec3) -> GroupRgb {
        match grid_of(&self.grids, point) {
            Some(grid) => self.irradiance_in(grid, point, normal),
            None => [Vec3::ZERO; 2],
        }
    }

    /// The blend of grid `grid`'s probes around `point`, evaluated for `normal`.
    fn irradiance_in(&self, grid: usize, point: Vec3, normal: Vec3) -> GroupRgb {
        self.blend_in(grid, point, normal).read(&self.cubes)
    }

    /// Which of grid `grid`'s probes a surface at `point` facing `normal` reads, and how: the
    /// eight around it trilinearly, less those inside solids, probes behind the surface
    /// weighing less.
    fn blend_in(&self, grid: usize, point: Vec3, normal: Vec3) -> Blend {
        let g = &self.grids[grid];
        let q = point + normal * NORMAL_BIAS_M;
        let f = ((q - g.lo) / g.step).max(Vec3::ZERO);
        let mut base = [0usize; 3];
        let mut frac = [0.0f32; 3];
        for axis in 0..3 {
            let top = (g.dims[axis] - 1) as f32;
            let fa = f[axis].min(top);
            base[axis] = (fa.floor() as usize).min(g.dims[axis] - 2);
            frac[axis] = fa - base[axis] as f32;
        }
        let mut blend = Blend::facing(normal);
        let mut weight_sum = 0.0f32;
        for corner in 0..8 {
            let offset = [corner & 1, (corner >> 1) & 1, corner >> 2];
            let mut w = 1.0f32;
            for axis in 0..3 {
                w *= if offset[axis] == 1 { frac[axis] } else { 1.0 - frac[axis] };
            }
            let cell = [base[0] + offset[0], base[1] + offset[1], base[2] + offset[2]];
            let index = g.first + cell[0] + g.dims[0] * (cell[1] + g.dims[1] * cell[2]);
            if w <= 0.0 || !self.valid[index] {
                continue;
            }
            // Probes behind the surface weigh less (a smooth back-face weight), and probes that
            // cannot see it drop out.
            let probe = g.lo + g.step * Vec3::new(cell[0] as f32, cell[1] as f32, cell[2] as f32);
            let towards = (probe - point).normalize_or_zero();
            let facing = 0.5 * (towards.dot(normal) + 1.0);
            let w = w * (facing * facing + 0.2) * visibility(&self.depths[index], q - probe);
            weight_sum += w;
            blend.probes[corner] = index as u32;
            blend.weights[corner] = w;
        }
        if weight_sum > 0.0 {
            blend.weights = blend.weights.map(|w| w / weight_sum);
        }
        blend
    }

    /// Probes in the volume.
    #[must_use]
    pub fn probe_count(&self) -> usize {
        self.valid.len()
    }

    /// Probes left out of the blends (inside a solid).
    #[must_use]
    pub fn invalid_probe_count(&self) -> usize {
        self.valid.iter().filter(|v| !**v).count()
    }

    /// Passes the bounce iteration ran.
    #[must_use]
    pub fn bounces(&self) -> u32 {
        self.bounces
    }

    /// Probe rays traced (shadow rays of their hits not counted).
    #[must_use]
    pub fn probe_rays(&self) -> u64 {
        self.probe_rays
    }
}

/// A volume with the [`fingerprint`] of its scene.
type Keyed = (u64, Arc<IrradianceVolume>);

/// Volumes [`IrradianceVolume::shared`] keeps (a few megabytes each: 1.2 KB per probe, most of
/// it the distance map).
pub const CACHED_VOLUMES: usize = 16;

/// A 64-bit digest of what a volume's build reads: the scene's geometry, materials, texels,
/// lights, rooms and envelope, the settings and the seed.
fn fingerprint(scene: &Scene, settings: &VolumeSettings, seed: u64) -> u64 {
    /// Feeds `Debug` output to a hasher without building the string.
    struct Digest(std::hash::DefaultHasher);
    impl std::fmt::Write for Digest {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            self.0.write(s.as_bytes());
            Ok(())
        }
    }
    let mut d = Digest(std::hash::DefaultHasher::new());
    let g = &scene.geometry;
    // Writing into a hasher cannot fail.
    let _ = write!(
        d,
        "{:?}{:?}{:?}{:?}{:?}{:?}{:?}{:?}{seed}",
        g.meshes, g.materials, g.nodes, scene.lights, scene.rooms, scene.envelope, scene.wall_thickness_m, settings
    );
    for texture in &g.textures {
        d.0.write_u32(texture.width);
        d.0.write_u32(texture.height);
        d.0.write(&texture.rgba8);
    }
    d.0.finish()
}

/// One grid per room interior, floor to ceiling; one grid around the geometry for a scene
/// without rooms.
fn grids_of(scene: &Scene, accel: &Accel, spacing_m: f32) -> Vec<ProbeGrid> {
    let mut grids = Vec::new();
    let mut first = 0;
    if scene.rooms.is_empty() {
        let (lo, hi) =
            accel.positions().iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        // Grown by half a spacing, so that no probe sits on a surface at the edge (a lone
        // floor gets probes above and below it, not in it).
        let pad = Vec3::splat(0.5 * spacing_m);
        if lo.cmple(hi).all() {
            // A scene without rooms can be anything (a 200 m test floor): its spacing grows
            // until the grid fits the probe budget.
            let mut spacing = spacing_m;
            let mut grid = ProbeGrid::over(lo - pad, hi + pad, spacing, 0);
            while grid.len() > MAX_FREE_GRID_PROBES {
                spacing *= 1.25;
                grid = ProbeGrid::over(lo - pad, hi + pad, spacing, 0);
            }
            grids.push(grid);
        }
        return grids;
    }
    let height = scene.envelope.height_m;
    for room in &scene.rooms {
        let (lo, hi) = room.interior(scene.wall_thickness_m);
        let grid = ProbeGrid::over(lo.extend(0.0), hi.extend(height), spacing_m, first);
        first += grid.len();
        grids.push(grid);
    }
    grids
}

/// `n` directions evenly over the sphere (a spherical Fibonacci set), turned by `rotation`.
fn sphere_directions(n: u32, rotation: Quat) -> impl Iterator<Item = Vec3> {
    const INV_PHI: f64 = 0.618_033_988_749_894_9;
    (0..n).map(move |i| {
        let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * (f64::from(i) * INV_PHI).fract() as f32;
        rotation * Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

/// A uniformly random rotation (Shoemake's method, from three uniform numbers).
fn random_rotation(sampler: &mut Sampler) -> Quat {
    let (u1, u2, u3) = (sampler.uniform(), sampler.uniform(), sampler.uniform());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (t2, t3) = (std::f32::consts::TAU * u2, std::f32::consts::TAU * u3);
    Quat::from_xyzw(a * t2.sin(), a * t2.cos(), b * t3.sin(), b * t3.cos()).normalize()
}

/// A cone of directions from a probe around a point light, sampled on its own ([`HOT_SPOTS`]): the surfaces
/// right next to a bulb (the ceiling above a ceiling light) are the brightest things in a
/// room at night, hold a large share of the light that bounces, and are small seen from
/// afar, so the probe's even rays would find them by chance and every probe would carry its
/// own large error.
#[derive(Clone, Copy, Debug)]
struct Cap {
    axis: Vec3,
    cos_half_angle: f32,
    solid_angle_sr: f32,
    /// How many times denser than the even rays the cap is sampled.
    density: f32,
}

impl Cap {
    fn contains(&self, d: Vec3) -> bool {
        d.dot(self.axis) >= self.cos_half_angle
    }

    /// The direction of `(u1, u2)` spread uniformly over the cap.
    fn direction(&self, u1: f32, u2: f32) -> Vec3 {
        let cos_t = 1.0 - u1 * (1.0 - self.cos_half_angle);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (t, b) = self.axis.any_orthonormal_pair();
        let phi = std::f32::consts::TAU * u2;
        (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + self.axis * cos_t).normalize_or(self.axis)
    }
}

/// Radii around a point light, metres, of the spheres whose caps are sampled apart, and how
/// many times denser than the even rays: a bulb 0.1 m under a ceiling puts 63 % of its upward
/// light within 0.25 m of its foot and 87 % within 0.75 m, and the light falls as the inverse
/// square of the distance from the bulb, so the inner cap takes the densest rays. With one
/// sparser cap the estimate is heavy-tailed: usually low, now and then one probe far too bright.
const HOT_SPOTS: [(f32, f32); 2] = [(0.25, 32.0), (0.75, 8.0)];
/// Fewest rays in a cap.
const MIN_CAP_RAYS: u32 = 8;

/// The caps of the probe at `p`: for each point light that can reach its room and each of
/// [`HOT_SPOTS`], the cap holding that sphere about the light (the whole sphere of directions
/// for a probe inside it); all inner caps first, so a direction near a light belongs to the
/// densest cap that holds it.
fn caps_at(lights: &LightSet, p: Vec3) -> Vec<Cap> {
    let points = &lights.reach.lights_at(p).points;
    HOT_SPOTS
        .iter()
        .flat_map(|&(radius_m, density)| {
            points.iter().filter_map(move |&i| {
                let to_light = lights.points[i as usize].position - p;
                let d = to_light.length();
                let axis = to_light.normalize_or_zero();
                if axis == Vec3::ZERO {
                    return None;
                }
                let cos_half_angle = if d <= radius_m { -1.0 } else { (1.0 - (radius_m / d).powi(2)).max(0.0).sqrt() };
                let solid_angle_sr = std::f32::consts::TAU * (1.0 - cos_half_angle);
                Some(Cap { axis, cos_half_angle, solid_angle_sr, density })
            })
        })
        .collect()
}

/// The rays of the probe at `p`: what each lit surface it meets sends back, and whether the
/// probe stands in free space (few back faces).
///
/// The sphere of directions is split into the caps around its point lights ([`Cap`]) and the
/// rest. The rest takes the even rays that fall outside every cap, each weighing `4 pi / rays`;
/// each cap takes its own rays, uniform over it, each weighing the cap's solid angle over its
/// ray count, less those inside an earlier cap. Both parts are unbiased estimates of their
/// share of the sphere, so the sum is one of the whole.
#[allow(clippy::too_many_arguments)]
fn gather_probe(
    scene: &Scene,
    accel: &Accel,
    lights: &LightSet,
    grids: &[ProbeGrid],
    p: Vec3,
    rays: u32,
    seed: u64,
    key: u64,
) -> Probe {
    let mut sampler = Sampler::new(seed, "render/irradiance-volume", key);
    let blockers = Blockers::default();
    let rotation = random_rotation(&mut sampler);
    let caps = caps_at(lights, p);
    let mut probe = ProbeRays { scene, accel, lights, grids, p, gathers: Vec::new(), traced: 0 };
    let even_weight = 4.0 * PI / rays as f32;
    let mut even_backfaces = 0u32;
    for dir in sphere_directions(rays, rotation) {
        let backface = if caps.iter().any(|c| c.contains(dir)) {
            probe.backface(dir)
        } else {
            probe.trace(dir, even_weight, &mut sampler, &blockers)
        };
        even_backfaces += u32::from(backface);
    }
    for (k, cap) in caps.iter().enumerate() {
        let even_rays_inside = rays as f32 * cap.solid_angle_sr / (4.0 * PI);
        let count = ((even_rays_inside * cap.density).ceil() as u32).max(MIN_CAP_RAYS);
        let weight = cap.solid_angle_sr / count as f32;
        let strata = Strata { first: 0, stride: 1, total: count, rotation: sampler.uniform() };
        for i in 0..count {
            let (u1, u2) = strata.point(i, &mut sampler);
            let dir = cap.direction(u1, u2);
            if !caps[..k].iter().any(|c| c.contains(dir)) {
                probe.trace(dir, weight, &mut sampler, &blockers);
            }
        }
    }
    // Judged on the even rays alone: the caps crowd their rays round a lamp, whose shade's
    // inside is a back face seen through its opening.
    let valid = (even_backfaces as f32) <= MAX_BACKFACE_FRACTION * rays as f32;
    Probe { gathers: probe.gathers, valid, depth: depth_map(accel, p), traced: probe.traced + DEPTH_BINS as u32 }
}

/// What [`gather_probe`] learns of one probe.
struct Probe {
    /// Its rays' lit hits.
    gathers: Vec<Gather>,
    /// Whether it stands in free space.
    valid: bool,
    /// How far its unshaded rays through the cells of its octahedral map went ([`depth_map`]).
    depth: DepthMap,
    /// Rays traced.
    traced: u32,
}

/// One probe's rays as they are traced.
struct ProbeRays<'a> {
    scene: &'a Scene,
    accel: &'a Accel,
    lights: &'a LightSet,
    grids: &'a [ProbeGrid],
    p: Vec3,
    gathers: Vec<Gather>,
    traced: u32,
}

impl ProbeRays<'_> {
    /// Whether the ray along `dir` meets a back face first (traced only for the count).
    fn backface(&mut self, dir: Vec3) -> bool {
        self.traced += 1;
        self.accel
            .closest_hit(self.p, dir, f32::INFINITY)
            .is_some_and(|h| self.accel.face_normal(h.triangle).dot(dir) > 0.0)
    }

    /// Traces the ray along `dir`, which stands for `weight` steradians of the sphere; whether
    /// it met a back face. A back face is still shaded (the renderer is two-sided: the inside
    /// of a lamp shade is lit), but many of them mean the probe is inside a solid.
    fn trace(&mut self, dir: Vec3, weight: f32, sampler: &mut Sampler, blockers: &Blockers) -> bool {
        self.traced += 1;
        let Some(hit) = self.accel.closest_hit(self.p, dir, f32::INFINITY) else { return false };
        let backface = self.accel.face_normal(hit.triangle).dot(dir) > 0.0;
        if self.lights.emitter_seen(self.p, dir, hit.t).is_some() {
            return backface;
        }
        let surface = self.accel.surface(&hit, self.p, dir);
        let albedo = surface_response(self.scene, &surface).diffuse;
        if albedo == Vec3::ZERO {
            return backface;
        }
        let (position, ng, ns) = (surface.position, surface.geometric_normal, surface.shading_normal);
        let e = self.lights.direct(
            self.accel,
            position,
            ng,
            ns,
            1,
            Strata::independent(sampler),
            super::DEFAULT_LIGHT_CULL,
            sampler,
            blockers,
        );
        let albedo_over_pi = albedo / PI;
        let lifted = position + ng * ray_epsilon(position);
        self.gathers.push(Gather {
            faces: cube_weights(dir).map(|v| v * weight),
            position: lifted,
            normal: ns,
            albedo_over_pi,
            direct: [e[0] * albedo_over_pi, e[1] * albedo_over_pi],
            grid: grid_of(self.grids, lifted).unwrap_or(0) as u32,
        });
        backface
    }
}

/// The grid of the room whose interior holds `point` in the top view, else the nearest;
/// `None` only without grids.
#[inline]
fn grid_of(grids: &[ProbeGrid], point: Vec3) -> Option<usize> {
    let mut best: Option<(usize, f32)> = None;
    for (i, g) in grids.iter().enumerate() {
        let d = g.distance_xy(point);
        if d == 0.0 {
            return Some(i);
        }
        if best.is_none_or(|(_, best_d)| d < best_d) {
            best = Some((i, d));
        }
    }
    best.map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_irradiance(cube: &Cube, n: Vec3) -> Vec3 {
        Blend::facing(n).seen(cube)
    }

    /// Every cell's centre direction folds back into its own cell, the cells cover the whole
    /// sphere (each of 20,000 spread directions lands in one, and every cell is hit), and no
    /// cell is much larger than another (the octahedral map is not equal-area: its cells span
    /// about 4x in solid angle).
    #[test]
    fn the_octahedral_cells_tile_the_sphere() {
        for bin in 0..DEPTH_BINS {
            let c = depth_bin_centre(bin);
            assert!((c.length() - 1.0).abs() < 1e-5);
            assert_eq!(depth_bin(c), bin, "centre {c} of cell {bin}");
        }
        let mut hits = [0u32; DEPTH_BINS];
        for d in sphere_directions(20_000, Quat::IDENTITY) {
            hits[depth_bin(d)] += 1;
        }
        let (lo, hi) = (hits.iter().min().copied().unwrap(), hits.iter().max().copied().unwrap());
        assert!(lo > 0 && hi < 5 * lo, "cells of {lo} to {hi} directions");
    }

    /// A probe whose ray that way met a surface 0.3 m off sees a point in front of it fully,
    /// a point 10 cm behind it (across a door leaf) hardly, and a point far behind not at all;
    /// where the ray met nothing, everything is seen.
    #[test]
    fn a_probe_does_not_see_past_what_its_rays_met() {
        let dir = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut depth = [MISS_DISTANCE_M; DEPTH_BINS];
        depth[depth_bin(dir)] = 0.3;
        assert_eq!(visibility(&depth, dir * 0.25), 1.0);
        assert!(visibility(&depth, dir * 0.4) < 0.01, "{}", visibility(&depth, dir * 0.4));
        assert_eq!(visibility(&depth, dir * 2.0), MIN_VISIBILITY);
        assert_eq!(visibility(&depth, -dir * 2.0), 1.0);
        // Just past the surface, within the spread its ray's direction allows.
        assert!(visibility(&depth, dir * 0.31) > 0.5);
    }

    /// A constant radiance `L` over the sphere gives irradiance `pi L` on every normal; `L`
    /// on the upper hemisphere only gives `pi L` facing up, nothing facing down and `pi L / 2`
    /// facing sideways, on the cube's faces exactly (up to the ray set's quadrature).
    #[test]
    fn the_cube_integrates_the_clamped_cosine() {
        let n = 4096;
        let w = 4.0 * PI / n as f32;
        let project = |f: &dyn Fn(Vec3) -> f32| {
            let mut cube = [Vec3::ZERO; 6];
            for d in sphere_directions(n, Quat::IDENTITY) {
                for (c, k) in cube.iter_mut().zip(cube_weights(d)) {
                    *c += Vec3::splat(f(d) * k * w);
                }
            }
            cube
        };
        let uniform = project(&|_| 1.0);
        for normal in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.3, -0.4, 0.866).normalize()] {
            let e = cube_irradiance(&uniform, normal).x;
            assert!((e - PI).abs() < 1e-3 * PI, "{normal}: {e}");
        }
        let sky = project(&|d| if d.z > 0.0 { 1.0 } else { 0.0 });
        assert!((cube_irradiance(&sky, Vec3::Z).x - PI).abs() < 1e-3 * PI);
        assert_eq!(cube_irradiance(&sky, Vec3::NEG_Z).x, 0.0, "a floor never sees its own light");
        assert!((cube_irradiance(&sky, Vec3::X).x - PI / 2.0).abs() < 1e-3 * PI);
    }

    #[test]
    fn fibonacci_directions_are_unit_and_balanced() {
        let mut sampler = Sampler::new(3, "t", 1);
        let dirs: Vec<Vec3> = sphere_directions(256, random_rotation(&mut sampler)).collect();
        assert!(dirs.iter().all(|d| (d.length() - 1.0).abs() < 1e-5));
        let mean = dirs.iter().copied().sum::<Vec3>() / dirs.len() as f32;
        assert!(mean.length() < 0.01, "mean direction {mean}");
    }

    #[test]
    fn grids_span_the_box_just_inside_its_faces() {
        let g = ProbeGrid::over(Vec3::ZERO, Vec3::new(5.0, 3.0, 3.0), 0.6, 7);
        assert_eq!(g.dims, [9, 6, 6]);
        assert_eq!(g.len(), 324);
        assert!((g.position(0) - Vec3::splat(0.02)).length() < 1e-5);
        let last = g.position(g.len() - 1);
        assert!((last - Vec3::new(4.98, 2.98, 2.98)).length() < 1e-5, "{last}");
        assert_eq!(g.distance_xy(Vec3::new(2.0, 1.0, 9.0)), 0.0);
        assert!((g.distance_xy(Vec3::new(6.0, 1.0, 0.0)) - 1.0).abs() < 1e-6);
    }
}
