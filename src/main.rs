//! The `scene-gen` command line. Library code returns typed errors; this binary turns them
//! into messages and exit statuses: 0 success, 1 failure while working, 2 bad input or usage.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {:#}", err.error);
            ExitCode::from(err.status())
        }
    }
}
