//! Measured camera data against the simulated camera.
//!
//! ```text
//! EMVA 1288 set or photon-transfer CSV ─► calibration ─► gap workflow ─► sensor model (TOML)
//! photographs of a test chart ─────────────────────────► target ──────► optics + noise effects
//! ```
//!
//! * [`calibration`]: EMVA 1288 descriptors and photon-transfer CSVs to measured sensor
//!   parameters (`scene-gen calibrate`).
//! * [`gap`]: compares measured and simulated statistics, names the effects the sensor model
//!   misses and adds them while each earns its place (`scene-gen gap`).
//! * [`target`]: the same loop for images of a test chart (`scene-gen target`): lens blur,
//!   motion blur, illumination fall-off and single-frame noise effects.
//! * [`search`]: the effect search both share: effects are types behind [`search::Effect`],
//!   each measurement a [`search::Problem`].

pub mod calibration;
pub mod gap;
pub mod least_squares;
pub mod search;
pub mod target;
