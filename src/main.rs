//! The `scene-gen` command line. Library code returns typed errors; this binary turns them
//! into messages and exit statuses: 0 success, 1 failure while working, 2 bad input or usage.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    keep_freed_buffers();
    // RUST_LOG=info (or debug) shows what each stage did; by default only warnings.
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args = cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", report(&err.error));
            ExitCode::from(err.status())
        }
    }
}

/// Has glibc's allocator serve every allocation from its heap and keep what is freed, instead
/// of mapping each large buffer fresh from the kernel and unmapping it when freed. A
/// native-resolution image takes tens of megabytes per stage (electrons, digital numbers,
/// demosaicing planes, bytes) and every pose allocates them again: mapped afresh, each page is
/// zeroed by the kernel on first touch, kernel time that grows with every pose
/// (docs/BENCHMARKS.md, "Native resolution"). The process keeps its peak heap until it exits.
fn keep_freed_buffers() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets allocator parameters; it is called before any thread starts.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

/// The error and its causes joined by `: `, each cause left out when the text so far already
/// says it: many library errors put their source in their own message (so they read well
/// alone) and also expose it as `source()` (so callers can inspect it), and printing both
/// would repeat it.
fn report(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::report;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot read a.toml: {source}")]
    struct Embedding {
        #[source]
        source: std::io::Error,
    }

    #[test]
    fn a_cause_already_in_the_message_is_said_once_and_a_new_one_is_kept() {
        let io = || std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let embedded = anyhow::Error::new(Embedding { source: io() });
        assert_eq!(report(&embedded), "cannot read a.toml: no such file");
        let wrapped = anyhow::Error::new(io()).context("loading the config");
        assert_eq!(report(&wrapped), "loading the config: no such file");
    }
}
