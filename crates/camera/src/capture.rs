//! The capture stage: a house, a camera and its lighting scenarios in, frames out.
//!
//! Every command that looks at a house through a camera (`render`, `dataset`, `evaluate`)
//! runs the same chain, and this module is the only place that wires it:
//!
//! ```text
//! pose ─► Renderer (radiance per light group, depth, ids, normals)
//!           └─► per scenario: lights scaled to the target lux ─► optics ─► photons ─► e-
//!                              ─► sensor noise ─► DN (SensorImage) ─► ISP ─► 8-bit image
//! ```
//!
//! A colour sensor ([`bayer::cfa_of`]) takes the Bayer branch: electrons per CFA channel through
//! the scenario's spectral matrix (its illuminant, [`illuminant`], replacing the tint the
//! renderer gave its lights, [`rendered_tint`]), noise on the mosaic, and the colour ISP to
//! sRGB ([`Scenario::image_8bit`]); perception sees that image's luma ([`PerceptionImage`]).
//!
//! A [`Capture`] is built once per house and camera: it builds the BVH, measures how far each
//! light group must be scaled to light the table-height plane at its scenario's target (20 lux
//! by day, 2 lux by night, [`ScenarioLight`]), and sets the fixed ISP of each scenario. Each
//! pose is then traced once ([`Capture::render`]); every scenario is a weighted sum of that one
//! trace, so day and night cost one render.
//!
//! Temporal noise is drawn per frame and scenario from a stream named by the caller's label
//! ([`Capture::frame_seed`]), so two commands that want different noise (a dataset and an
//! evaluation of the same house) get it, and each gets the same bytes on every run.

use glam::Vec3;
use scene_gen_render::{Camera, Frame, RenderError, RenderSettings, Renderer, measure_mean_illuminance};
use scene_gen_scene::lights::{DAY_TARGET_LUX, NIGHT_TARGET_LUX, TARGET_PLANE_M};
use scene_gen_scene::scene::{LightGroup, Scene};
use scene_gen_scene::trajectory::Pose;

use crate::bayer::{self, ColourIsp, Radiance};
use crate::camera_spec::{NoiseKind, ResolvedCamera};
use crate::isp::{self, Isp, OutputRule};
use crate::optics::{OpticsInput, agent_velocity};
use crate::radiometry::{SensorImage, capture_frame};
use crate::spectral::{ChannelMatrix, Illuminant, NIGHT_CCT_K, QeCurves};

/// Why a capture could not be set up or a frame not be taken.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error("rendering house {seed}: {source}")]
    Render {
        seed: u64,
        #[source]
        source: RenderError,
    },
    #[error("{group:?} lights give no light on the {TARGET_PLANE_M} m plane")]
    NoLight { group: LightGroup },
}

/// How one light group is scaled for its scenario: the lights of `group` scaled by `scale` so
/// the mean illuminance on the [`TARGET_PLANE_M`] plane, `nominal_lux` as generated, becomes
/// `target_lux`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenarioLight {
    pub group: LightGroup,
    pub nominal_lux: f32,
    pub scale: f32,
    pub target_lux: f32,
}

impl ScenarioLight {
    /// The scenario's name in file names and noise streams: `day` or `night`.
    #[must_use]
    pub fn name(&self) -> &'static str {
        scenario_name(self.group)
    }

    /// The weights of the frame's day and night radiance in this scenario: the scale on its
    /// own group, 0 on the other.
    #[must_use]
    pub fn weights(&self) -> (f32, f32) {
        match self.group {
            LightGroup::Day => (self.scale, 0.0),
            LightGroup::Night => (0.0, self.scale),
        }
    }

    /// The scenario's radiance of a frame: its group's radiance, scaled.
    #[must_use]
    pub fn radiance(&self, frame: &Frame) -> Vec<[f32; 3]> {
        let (day_weight, night_weight) = self.weights();
        frame.mix(day_weight, night_weight)
    }

    /// [`ScenarioLight::radiance`] as a view of the frame, for passes that read it once.
    #[must_use]
    pub fn radiance_of<'f>(&self, frame: &'f Frame) -> Radiance<'f> {
        let (day_weight, night_weight) = self.weights();
        Radiance::Mix { day: &frame.day_nit, night: &frame.night_nit, day_weight, night_weight }
    }
}

/// `day` or `night`.
#[must_use]
pub fn scenario_name(group: LightGroup) -> &'static str {
    match group {
        LightGroup::Day => "day",
        LightGroup::Night => "night",
    }
}

/// The target illuminance of a light group's scenario on the table-height plane: 20 lux by day,
/// 2 lux by night (the reference system's scenarios).
#[must_use]
pub fn target_lux(group: LightGroup) -> f32 {
    match group {
        LightGroup::Day => DAY_TARGET_LUX,
        LightGroup::Night => NIGHT_TARGET_LUX,
    }
}

/// The scale of each group's lights that brings the mean illuminance on the table-height plane
/// to its scenario's target ([`target_lux`]), in the order of `groups`.
///
/// # Errors
/// A render error of the probe rays, or [`CaptureError::NoLight`] when a group gives no light.
pub fn light_scales(
    renderer: &Renderer<'_>,
    seed: u64,
    groups: &[LightGroup],
) -> Result<Vec<ScenarioLight>, CaptureError> {
    groups
        .iter()
        .map(|&group| {
            let target = target_lux(group);
            let nominal = measure_mean_illuminance(renderer, group, TARGET_PLANE_M)
                .map_err(|source| CaptureError::Render { seed, source })?;
            if nominal <= 0.0 {
                return Err(CaptureError::NoLight { group });
            }
            Ok(ScenarioLight { group, nominal_lux: nominal, scale: target / nominal, target_lux: target })
        })
        .collect()
}

/// The spectrum of a light group's scenario: CIE D65 by day, warm-white (a
/// [`NIGHT_CCT_K`] Planckian radiator) by night.
#[must_use]
pub fn illuminant(group: LightGroup) -> Illuminant {
    match group {
        LightGroup::Day => Illuminant::D65,
        LightGroup::Night => Illuminant::Planck(NIGHT_CCT_K),
    }
}

/// The colour the scene's renderer gives a light group (linear sRGB, any scale): white by day
/// (the scene's sun and sky tints average to about D65, whose colour is the sRGB white), by
/// night the intensity-weighted mean colour of the group's lights (the lamps' warm tints). The
/// colour capture divides it out and applies the scenario's [`illuminant`] spectrum instead.
#[must_use]
pub fn rendered_tint(scene: &Scene, group: LightGroup) -> [f64; 3] {
    if group == LightGroup::Day {
        return [1.0; 3];
    }
    let mut sum = [0.0f64; 3];
    for light in scene.lights.iter().filter(|l| l.group == group) {
        (0..3).for_each(|c| sum[c] += f64::from(light.color[c]) * f64::from(light.intensity));
    }
    if sum.iter().all(|&v| v > 0.0) { sum } else { [1.0; 3] }
}

/// One scenario of a capture: its light, gain and ISP.
#[derive(Clone, Copy, Debug)]
pub struct Scenario {
    pub light: ScenarioLight,
    /// Analogue gain, dB (the camera spec's day or night gain).
    pub gain_db: f64,
    /// The fixed grey ISP of this camera at this gain and target illuminance (the evaluator's
    /// luminance image).
    pub isp: Isp,
    /// The colour ISP, for a camera that samples through a CFA ([`bayer::cfa_of`]).
    pub colour: Option<ColourIsp>,
}

/// An 8-bit image as the camera's ISP writes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image8 {
    pub width: u32,
    pub height: u32,
    /// 1 (grey) or 3 (sRGB, interleaved).
    pub channels: u8,
    pub bytes: Vec<u8>,
}

/// One scenario's image as perception sees it: the grey image ORB and the built-in detector
/// read, and for a colour camera the sRGB image it came from (interleaved RGB), which plug-in
/// detectors are given.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PerceptionImage {
    pub grey: Vec<u8>,
    pub rgb: Option<Vec<u8>>,
}

/// The luma of interleaved 8-bit sRGB, as OpenCV's `cvtColor(RGB2GRAY)` computes it (Rec. 601
/// weights 0.299, 0.587, 0.114 in 14-bit fixed point, rounded): what a robot's vision stack
/// hands ORB from a colour camera.
#[must_use]
pub fn luma_of_srgb(rgb: &[u8]) -> Vec<u8> {
    const R: u32 = 4899;
    const G: u32 = 9617;
    const B: u32 = 1868;
    rgb.chunks_exact(3)
        .map(|p| ((u32::from(p[0]) * R + u32::from(p[1]) * G + u32::from(p[2]) * B + (1 << 13)) >> 14) as u8)
        .collect()
}

impl Scenario {
    /// The 8-bit image of a capture of this scenario: a raw mosaic developed to sRGB, a grey
    /// capture through the grey ISP, the affine path's 8-bit RGB as it is.
    ///
    /// # Panics
    /// If a mosaic comes without this scenario's colour ISP.
    #[must_use]
    pub fn image_8bit(&self, raw: &SensorImage) -> Image8 {
        let (width, height) = (raw.width, raw.height);
        if raw.cfa.is_some() {
            let colour = self.colour.as_ref().expect("a mosaic has its scenario's colour ISP");
            return Image8 { width, height, channels: 3, bytes: colour.develop(raw) };
        }
        if raw.channels == 3 {
            return Image8 { width, height, channels: 3, bytes: raw.dn.iter().map(|&v| v.min(255) as u8).collect() };
        }
        Image8 { width, height, channels: 1, bytes: isp::to_8bit(raw, OutputRule::Isp, &self.isp) }
    }
}

/// A camera in a house under one or more lighting scenarios (see the module docs).
pub struct Capture<'a> {
    renderer: Renderer<'a>,
    camera: &'a ResolvedCamera,
    scenarios: Vec<Scenario>,
    /// Seed of the sensor instance's fixed patterns (the house seed).
    pattern_seed: u64,
    /// Walking speed of the agent, m/s, for motion blur.
    walk_speed_m_s: f32,
    /// Prefix of the temporal-noise streams ([`Capture::frame_seed`]).
    noise_label: String,
}

impl std::fmt::Debug for Capture<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Capture")
            .field("camera", &self.camera.sensor.model)
            .field("scenarios", &self.scenarios)
            .finish_non_exhaustive()
    }
}

impl<'a> Capture<'a> {
    /// Prepares `camera` in `scene` for the scenarios of `groups` (in that order), rendering
    /// with `settings`; the agent walks at `walk_speed_m_s`. Temporal noise streams are named
    /// `{noise_label}{key}/{scenario}` ([`Capture::frame_seed`]).
    ///
    /// # Errors
    /// [`CaptureError`] when the light probe fails or a group gives no light.
    pub fn new(
        scene: &'a Scene,
        camera: &'a ResolvedCamera,
        groups: &[LightGroup],
        settings: RenderSettings,
        walk_speed_m_s: f32,
        noise_label: impl Into<String>,
    ) -> Result<Capture<'a>, CaptureError> {
        let renderer = Renderer::new(scene, settings);
        let channels = if camera.spec.noise == NoiseKind::Affine { 3 } else { 1 };
        let curves = QeCurves::typical_bayer(camera.sensor.quantum_efficiency);
        let scenarios = light_scales(&renderer, scene.seed, groups)?
            .into_iter()
            .map(|light| {
                let gain_db = match light.group {
                    LightGroup::Day => camera.spec.gain_day_db,
                    LightGroup::Night => camera.spec.gain_night_db,
                };
                let target_lux = f64::from(light.target_lux);
                let isp = Isp::for_scenario(camera, gain_db, target_lux, channels);
                let colour = bayer::cfa_of(camera).map(|pattern| {
                    let matrix =
                        ChannelMatrix::new(&curves, illuminant(light.group), rendered_tint(scene, light.group));
                    ColourIsp::for_scenario(camera, pattern, matrix, gain_db, target_lux)
                });
                Scenario { light, gain_db, isp, colour }
            })
            .collect();
        Ok(Capture {
            renderer,
            camera,
            scenarios,
            pattern_seed: scene.seed,
            walk_speed_m_s,
            noise_label: noise_label.into(),
        })
    }

    /// The renderer, for passes beyond a frame (ids over a box, labels only).
    #[must_use]
    pub fn renderer(&self) -> &Renderer<'a> {
        &self.renderer
    }

    /// The camera being simulated.
    #[must_use]
    pub fn camera(&self) -> &ResolvedCamera {
        self.camera
    }

    /// The scenarios, in the order they were asked for.
    #[must_use]
    pub fn scenarios(&self) -> &[Scenario] {
        &self.scenarios
    }

    /// The pinhole of the camera at `pose`.
    #[must_use]
    pub fn pinhole(&self, pose: &Pose) -> Camera {
        self.camera.camera_at(pose)
    }

    /// Renders the view from `pose`: radiance per light group, depth, ids and normals.
    ///
    /// # Errors
    /// [`CaptureError::Render`].
    pub fn render(&self, pinhole: &Camera) -> Result<Frame, CaptureError> {
        self.renderer.render(pinhole).map_err(|source| self.render_error(source))
    }

    /// [`Capture::render`] into a frame whose buffers are reused.
    ///
    /// # Errors
    /// [`CaptureError::Render`].
    pub fn render_into(&self, pinhole: &Camera, frame: &mut Frame) -> Result<(), CaptureError> {
        self.renderer.render_into(pinhole, frame).map_err(|source| self.render_error(source))
    }

    fn render_error(&self, source: RenderError) -> CaptureError {
        CaptureError::Render { seed: self.pattern_seed, source }
    }

    /// The temporal-noise seed of frame `key` in scenario `scenario`: the FNV-1a hash of
    /// `{noise_label}{key}/{day|night}`.
    #[must_use]
    pub fn frame_seed(&self, key: u64, scenario: &Scenario) -> u64 {
        scene_gen_core::rng::fnv1a64(format!("{}{key}/{}", self.noise_label, scenario.light.name()).as_bytes())
    }

    /// The camera's velocity on the walk at `pose`, for motion blur.
    fn velocity(&self, pose: &Pose) -> Vec3 {
        agent_velocity(&self.camera.spec, pose.yaw_deg, self.walk_speed_m_s)
    }

    /// The sensor's digital numbers of `frame` (rendered from `pose` through `pinhole`) in
    /// `scenario`, with the temporal noise of frame `key`.
    #[must_use]
    pub fn sensor_image(
        &self,
        frame: &Frame,
        pinhole: &Camera,
        pose: &Pose,
        scenario: &Scenario,
        key: u64,
    ) -> SensorImage {
        if scenario.colour.is_some() {
            return self.mosaics(frame, pinhole, pose, &[scenario], key).remove(0);
        }
        let optics = OpticsInput { depth_m: &frame.depth_m, velocity_m_s: self.velocity(pose) };
        capture_frame(
            self.camera,
            pinhole,
            &scenario.light.radiance(frame),
            Some(optics),
            scenario.gain_db,
            self.pattern_seed,
            self.frame_seed(key, scenario),
        )
    }

    /// The raw mosaics of `scenarios` (each with its colour ISP) of one frame, taken together
    /// ([`bayer::capture_mosaics`]).
    ///
    /// # Panics
    /// If a scenario has no colour ISP.
    fn mosaics<'s>(
        &self,
        frame: &Frame,
        pinhole: &Camera,
        pose: &Pose,
        scenarios: &[&'s Scenario],
        key: u64,
    ) -> Vec<SensorImage> {
        let colour = |s: &'s Scenario| s.colour.as_ref().expect("a colour camera's scenario has its colour ISP");
        let Some(first) = scenarios.first() else { return Vec::new() };
        let takes: Vec<bayer::MosaicScenario<'_>> = scenarios
            .iter()
            .map(|&s| bayer::MosaicScenario {
                radiance: s.light.radiance_of(frame),
                matrix: &colour(s).matrix,
                gain_db: s.gain_db,
                frame_seed: self.frame_seed(key, s),
            })
            .collect();
        let pattern = colour(first).develop.pattern;
        let optics = OpticsInput { depth_m: &frame.depth_m, velocity_m_s: self.velocity(pose) };
        bayer::capture_mosaics(self.camera, pinhole, Some(optics), pattern, self.pattern_seed, &takes)
    }

    /// [`Capture::sensor_image`] of every scenario, in the scenarios' order: what `render`,
    /// `dataset` and the Python package record of one view. A colour camera's mosaics are taken
    /// together ([`bayer::capture_mosaics`]).
    #[must_use]
    pub fn sensor_images(&self, frame: &Frame, pinhole: &Camera, pose: &Pose, key: u64) -> Vec<SensorImage> {
        if self.is_colour() {
            return self.mosaics(frame, pinhole, pose, &self.scenarios.iter().collect::<Vec<_>>(), key);
        }
        self.scenarios.iter().map(|scenario| self.sensor_image(frame, pinhole, pose, scenario, key)).collect()
    }

    /// Whether the camera samples through a CFA (every scenario then has its colour ISP).
    fn is_colour(&self) -> bool {
        self.scenarios.iter().any(|s| s.colour.is_some())
    }

    /// What perception sees of every scenario of `frame` under `rule` ([`PerceptionImage`]).
    ///
    /// A grey (monochrome or affine-path) camera: the bytes of [`Capture::sensor_image`]
    /// through [`isp::to_8bit`], by the fused row path of [`isp::capture_8bit`] where it
    /// applies. A colour camera under [`OutputRule::Isp`]: its mosaic developed to sRGB
    /// ([`Scenario::image_8bit`]), and that image's luma ([`luma_of_srgb`]); under
    /// [`OutputRule::TopBits`], the top 8 bits of the raw mosaic.
    #[must_use]
    pub fn images_8bit(
        &self,
        frame: &Frame,
        pinhole: &Camera,
        pose: &Pose,
        key: u64,
        rule: OutputRule,
    ) -> Vec<PerceptionImage> {
        if self.is_colour() {
            return self
                .sensor_images(frame, pinhole, pose, key)
                .into_iter()
                .zip(&self.scenarios)
                .map(|(raw, s)| match rule {
                    OutputRule::Isp => {
                        let rgb = s.image_8bit(&raw).bytes;
                        PerceptionImage { grey: luma_of_srgb(&rgb), rgb: Some(rgb) }
                    }
                    OutputRule::TopBits => {
                        PerceptionImage { grey: isp::to_8bit(&raw, OutputRule::TopBits, &s.isp), rgb: None }
                    }
                })
                .collect();
        }
        let seeds: Vec<u64> = self.scenarios.iter().map(|s| self.frame_seed(key, s)).collect();
        let scenarios: Vec<isp::Scenario<'_>> = self
            .scenarios
            .iter()
            .zip(&seeds)
            .map(|(s, &frame_seed)| {
                let (day_weight, night_weight) = s.light.weights();
                isp::Scenario { day_weight, night_weight, gain_db: s.gain_db, frame_seed, isp: &s.isp }
            })
            .collect();
        let optics = OpticsInput { depth_m: &frame.depth_m, velocity_m_s: self.velocity(pose) };
        isp::capture_8bit(
            self.camera,
            pinhole,
            &frame.day_nit,
            &frame.night_nit,
            Some(optics),
            self.pattern_seed,
            rule,
            &scenarios,
        )
        .into_iter()
        .map(|grey| PerceptionImage { grey, rgb: None })
        .collect()
    }
}
