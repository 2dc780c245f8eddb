//! `Dataset`: the dataset writer of `scene-gen dataset`, one seed at a time or all at once.
//!
//! A dataset folder is fixed by its `dataset.json`; any process that opens the folder
//! ([`Dataset::open`]) makes the same bytes for a seed, so seeds can be farmed out to other
//! processes or machines (the `scene_gen.ray` helpers) and merged once all are done.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use scene_gen::dataset::{
    self, Dataset as Writer, DatasetError, DatasetSpec, FrameSelection, Lighting, Quality, SeedReport, Shard,
};

use crate::camera::Camera;
use crate::progress::Callback;
use crate::{bad_input, failure, house, write_error};

/// A dataset folder and the spec that fixes every byte in it.
#[pyclass(frozen, module = "scene_gen._native")]
#[derive(Debug)]
pub struct Dataset {
    writer: Writer,
}

/// Bad input (spec, shard, a folder of other settings) or a failure of the work.
fn classify(e: DatasetError) -> PyErr {
    match e {
        DatasetError::Spec(_) | DatasetError::Shard(_) | DatasetError::Invalid(_) | DatasetError::Mismatch { .. } => {
            bad_input(e)
        }
        DatasetError::Write(_) => write_error(e),
        other => failure(other),
    }
}

/// The lightings of a `lighting` argument: `day`, `night` or `both`.
pub fn lighting(name: &str) -> PyResult<Vec<Lighting>> {
    match name {
        "day" => Ok(vec![Lighting::Day]),
        "night" => Ok(vec![Lighting::Night]),
        "both" => Ok(vec![Lighting::Day, Lighting::Night]),
        other => Err(bad_input(format!("lighting '{other}': expected 'day', 'night' or 'both'"))),
    }
}

/// The render quality of a `quality` argument: `evaluator`, `preview`, `standard` or `high`.
pub fn quality(name: &str) -> PyResult<Quality> {
    match name {
        "evaluator" => Ok(Quality::Evaluator),
        "preview" => Ok(Quality::Preview),
        "standard" => Ok(Quality::Standard),
        "high" => Ok(Quality::High),
        other => Err(bad_input(format!("quality '{other}': expected 'evaluator', 'preview', 'standard' or 'high'"))),
    }
}

fn report(r: SeedReport) -> (usize, usize, usize) {
    (r.frames, r.rendered, r.skipped)
}

#[pymethods]
impl Dataset {
    /// A dataset in `out` of `camera` over the houses of `seeds` (`"A..B"`, `"A..=B"` or one
    /// seed); checks everything and refuses a folder holding a dataset of other settings, but
    /// writes nothing.
    #[new]
    #[pyo3(signature = (out, camera, seeds, lighting="both", frames=None, every=None, max_width=None, quality="standard", envelope=None, min_room=None, rooms=None, furniture=None, raw=false))]
    #[allow(clippy::too_many_arguments)] // The keyword arguments of the Python call.
    fn new(
        out: PathBuf,
        camera: &Camera,
        seeds: &str,
        lighting: &str,
        frames: Option<u32>,
        every: Option<u32>,
        max_width: Option<u32>,
        quality: &str,
        envelope: Option<&str>,
        min_room: Option<f32>,
        rooms: Option<PathBuf>,
        furniture: Option<PathBuf>,
        raw: bool,
    ) -> PyResult<Dataset> {
        let seeds = dataset::parse_seeds(seeds).map_err(bad_input)?;
        let frames = match (frames, every) {
            (Some(_), Some(_)) => return Err(bad_input("give frames or every, not both")),
            (Some(k), None) => FrameSelection::Count { frames: k },
            (None, Some(n)) => FrameSelection::Every { step: n },
            (None, None) => FrameSelection::All,
        };
        let house = house::checked_options(envelope, min_room, rooms, furniture)?;
        let spec = DatasetSpec {
            house,
            raw,
            ..DatasetSpec::new(
                seeds,
                camera.spec_binned(max_width)?,
                self::lighting(lighting)?,
                frames,
                self::quality(quality)?,
            )
        };
        Dataset::checked(&out, spec)
    }

    /// The dataset already in the folder `out` (its `dataset.json`), as another process made it.
    #[staticmethod]
    fn open(out: PathBuf) -> PyResult<Dataset> {
        let path = out.join("dataset.json");
        let text = std::fs::read_to_string(&path).map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
        let spec: DatasetSpec = serde_json::from_str(&text)
            .map_err(|e| bad_input(format!("{}: not a dataset spec: {e}", path.display())))?;
        Dataset::checked(&out, spec)
    }

    /// The folder.
    #[getter]
    fn out(&self) -> PathBuf {
        self.writer.dir.clone()
    }

    /// Every seed of the dataset, in order.
    fn seeds(&self) -> Vec<u64> {
        self.writer.spec.seeds().iter().collect()
    }

    /// Image width and height in pixels.
    fn image_size(&self) -> (u32, u32) {
        self.writer.image_size()
    }

    /// `dataset.json`'s text.
    fn spec_json(&self) -> String {
        self.writer.spec.to_json()
    }

    /// Creates the folder and writes `dataset.json` (once).
    fn init(&self) -> PyResult<()> {
        self.writer.init().map_err(classify)
    }

    /// Makes every missing frame of `seed`, then its fragment; returns (frames, rendered,
    /// already there). The GIL is released while Rust works.
    #[pyo3(signature = (seed, progress=None))]
    fn run_seed(&self, py: Python<'_>, seed: u64, progress: Option<Py<PyAny>>) -> PyResult<(usize, usize, usize)> {
        if !self.writer.spec.seeds().iter().any(|s| s == seed) {
            return Err(bad_input(format!("seed {seed} is not in this dataset's seeds")));
        }
        self.writer.init().map_err(classify)?;
        let callback = Callback::new(progress, 0);
        let result = py.detach(|| self.writer.run_seed(seed, &callback));
        callback.finish()?;
        result.map(report).map_err(classify)
    }

    /// Runs shard `index` of `count` (the seeds numbered `index` mod `count`).
    #[pyo3(signature = (index=0, count=1, progress=None))]
    fn run_shard(
        &self,
        py: Python<'_>,
        index: u64,
        count: u64,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<(usize, usize, usize)> {
        let shard: Shard = format!("{index}/{count}").parse().map_err(bad_input)?;
        self.writer.init().map_err(classify)?;
        let callback = Callback::new(progress, 0);
        let result = py.detach(|| self.writer.run_shard(shard, &callback));
        callback.finish()?;
        result.map(report).map_err(classify)
    }

    /// Seeds without a fragment yet.
    fn missing_seeds(&self) -> Vec<u64> {
        self.writer.missing_seeds()
    }

    /// Merges the fragments into `annotations/instances_<lighting>.json` (every seed must be
    /// done); returns the annotation files, written or already up to date.
    fn merge(&self, py: Python<'_>) -> PyResult<Vec<PathBuf>> {
        py.detach(|| self.writer.merge()).map_err(classify)?;
        Ok(self.writer.spec.lighting.iter().map(|&l| self.writer.annotations_path(l)).collect())
    }

    fn __repr__(&self) -> String {
        let s = self.writer.spec.seeds();
        format!("Dataset({:?}, seeds {}..={})", self.writer.dir, s.first, s.last)
    }
}

impl Dataset {
    fn checked(out: &Path, spec: DatasetSpec) -> PyResult<Dataset> {
        let writer = Writer::new(out, spec).map_err(classify)?;
        writer.check_dir().map_err(classify)?;
        Ok(Dataset { writer })
    }
}
