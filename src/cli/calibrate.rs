//! `scene-gen calibrate MEASURED`: EMVA 1288 calibration of a measured camera.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;
use scene_gen::calibration::{Calibration, calibrate_path};

use super::sensors::emit;
use super::{CliError, bad_input, failure};

#[derive(Args, Debug)]
pub struct CalibrateArgs {
    /// An EMVA 1288 descriptor (with its images) or a photon-transfer CSV (`.csv`).
    pub measured: PathBuf,
    /// Print machine-readable results only (a JSON array, one entry per gain setting).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &CalibrateArgs) -> Result<(), CliError> {
    let results = calibrate_path(&args.measured).map_err(bad_input)?;
    if args.json {
        emit(&format!("{}\n", serde_json::to_string_pretty(&results).map_err(failure)?));
    } else {
        let mut out = String::new();
        for c in &results {
            print_table(&mut out, c);
        }
        emit(&out);
    }
    Ok(())
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "n/a".to_string(), |v| format!("{v:.digits$}"))
}

fn print_table(out: &mut String, c: &Calibration) {
    let _ = writeln!(out, "EMVA 1288 calibration of {}", c.source);
    if let Some(g) = c.gain_db {
        let _ = writeln!(out, "  gain                      {g} dB");
    }
    let _ = writeln!(out, "  points (K fit)            {} ({})", c.points, c.k_fit_points);
    let _ = writeln!(
        out,
        "  system gain K             {:.5} DN/e- ({}; plain EMVA fit {:.5})",
        c.system_gain_k_dn_per_e, c.k_method, c.system_gain_k_standard_dn_per_e
    );
    let _ = writeln!(out, "  dark level                {:.2} DN", c.dark_mean_dn);
    let _ = writeln!(out, "  temporal dark noise       {:.3} DN = {:.2} e-", c.dark_noise_dn, c.dark_noise_e);
    let _ = writeln!(
        out,
        "  quantum efficiency        {} (plain EMVA fit {})",
        opt(c.quantum_efficiency, 4),
        opt(c.quantum_efficiency_standard, 4)
    );
    let _ = writeln!(out, "  responsivity              {} DN/photon", opt(c.responsivity_dn_per_photon, 5));
    let _ = writeln!(
        out,
        "  saturation                {:.1} DN, {:.0} e-{}",
        c.saturation_mean_dn,
        c.saturation_capacity_e,
        if c.saturation_reached { "" } else { " (not reached: last step)" }
    );
    let _ = writeln!(out, "  dynamic range             {:.1} dB", c.dynamic_range_db);
    let _ = writeln!(out, "  linearity error           {} %", opt(c.linearity_error_percent, 3));
    let _ =
        writeln!(out, "  dark current              {} e-/s ({})", opt(c.dark_current.e_per_s, 3), c.dark_current.note);
    if let Some(s) = &c.spatial {
        let _ = writeln!(
            out,
            "  DSNU                      {:.3} DN = {:.2} e- (high-pass {:.3} DN)",
            s.dsnu_dn, s.dsnu_e, s.dsnu_highpass_dn
        );
        let _ = writeln!(
            out,
            "  PRNU                      {} % (high-pass {} %)",
            opt(s.prnu_percent, 3),
            opt(s.prnu_highpass_percent, 3)
        );
    } else {
        let _ = writeln!(out, "  DSNU / PRNU               n/a (no spatial stacks)");
    }
    let _ = writeln!(
        out,
        "  affine (TaCOS) at this gain: sigma_p^2 = {:.5}, sigma_t^2 = {:.4} DN^2",
        c.affine.sigma_p2, c.affine.sigma_t2_dn2
    );
}
