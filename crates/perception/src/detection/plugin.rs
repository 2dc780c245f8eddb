//! Runs an external detector process under the JSON-lines protocol of the [module
//! docs](super), and parses its answers into COCO detection records.

use std::collections::BTreeSet;
use std::io::Write;
use std::process::{Command, Stdio};

use serde::{Deserialize, Serialize};

use super::coco_eval::DetectionRecord;

/// One image for the detector.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PluginRequest {
    pub image_id: u64,
    pub path: String,
    pub width: u32,
    pub height: u32,
}

/// One detection in a response.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PluginDetection {
    pub category_id: u32,
    pub bbox: [f64; 4],
    pub score: f64,
}

/// The detector's answer for one image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PluginResponse {
    pub image_id: u64,
    pub detections: Vec<PluginDetection>,
}

/// Why an external detector run failed.
#[derive(Debug, thiserror::Error)]
pub enum PluginError {
    #[error("could not start detector {program}: {source}")]
    Spawn { program: String, source: std::io::Error },
    #[error("talking to detector {program}: {source}")]
    Io { program: String, source: std::io::Error },
    #[error("detector {program} exited with {status}")]
    Failed { program: String, status: std::process::ExitStatus },
    #[error("detector output line {line}: {why}")]
    BadLine { line: usize, why: String },
    #[error("detector gave no response for image {image_id}")]
    Missing { image_id: u64 },
}

/// Parses the detector's standard output against the requests it answers.
///
/// # Errors
/// [`PluginError::BadLine`] for invalid JSON, an unknown or repeated image id or a non-finite
/// number (naming the 1-based line); [`PluginError::Missing`] for an unanswered image.
pub fn parse_responses(output: &str, requests: &[PluginRequest]) -> Result<Vec<DetectionRecord>, PluginError> {
    let wanted: BTreeSet<u64> = requests.iter().map(|r| r.image_id).collect();
    let mut answered = BTreeSet::new();
    let mut records = Vec::new();
    for (i, text) in output.lines().enumerate() {
        let line = i + 1;
        if text.trim().is_empty() {
            continue;
        }
        let r: PluginResponse =
            serde_json::from_str(text).map_err(|e| PluginError::BadLine { line, why: e.to_string() })?;
        if !wanted.contains(&r.image_id) {
            return Err(PluginError::BadLine { line, why: format!("image_id {} was not requested", r.image_id) });
        }
        if !answered.insert(r.image_id) {
            return Err(PluginError::BadLine { line, why: format!("image_id {} answered twice", r.image_id) });
        }
        for d in r.detections {
            if !(d.bbox.iter().all(|v| v.is_finite()) && d.score.is_finite()) {
                return Err(PluginError::BadLine { line, why: "bbox and score must be finite".into() });
            }
            records.push(DetectionRecord {
                image_id: r.image_id,
                category_id: d.category_id,
                bbox: d.bbox,
                score: d.score,
            });
        }
    }
    if let Some(&image_id) = wanted.difference(&answered).next() {
        return Err(PluginError::Missing { image_id });
    }
    Ok(records)
}

/// Runs `program args...`, sends `requests` as JSON lines and parses the answers. Records come
/// out in the order the detector wrote them.
///
/// # Errors
/// Any [`PluginError`].
pub fn run(program: &str, args: &[String], requests: &[PluginRequest]) -> Result<Vec<DetectionRecord>, PluginError> {
    let io = |source| PluginError::Io { program: program.to_string(), source };
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|source| PluginError::Spawn { program: program.to_string(), source })?;
    let mut input = String::new();
    for r in requests {
        // Serialising a plain struct of numbers and a string cannot fail.
        input.push_str(&serde_json::to_string(r).unwrap_or_default());
        input.push('\n');
    }
    let mut stdin = child.stdin.take().ok_or_else(|| io(std::io::Error::other("no stdin")))?;
    // Write from a thread so a detector that answers before reading everything cannot block us.
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()));
    let out = child.wait_with_output().map_err(io)?;
    let written = writer.join().map_err(|_| io(std::io::Error::other("writer thread panicked")))?;
    // The exit status first: a detector that fails before reading its input also breaks the
    // pipe, and its failure, not the pipe, is what the user must hear about.
    if !out.status.success() {
        return Err(PluginError::Failed { program: program.to_string(), status: out.status });
    }
    // A detector may exit 0 without reading every request; the missing answers are then
    // reported by name below, which says more than the broken pipe would.
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => return Err(io(e)),
        _ => {}
    }
    parse_responses(&String::from_utf8_lossy(&out.stdout), requests)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(id: u64) -> PluginRequest {
        PluginRequest { image_id: id, path: format!("/tmp/{id}.png"), width: 64, height: 48 }
    }

    #[test]
    fn parses_answers_and_rejects_bad_ones() {
        let reqs = [req(1), req(2)];
        let out = "{\"image_id\": 2, \"detections\": []}\n\n{\"image_id\": 1, \"detections\": \
                   [{\"category_id\": 3, \"bbox\": [1, 2, 3, 4], \"score\": 0.5}]}\n";
        let recs = parse_responses(out, &reqs).unwrap();
        assert_eq!(recs.len(), 1);
        assert_eq!(recs[0].image_id, 1);
        assert_eq!(recs[0].bbox, [1.0, 2.0, 3.0, 4.0]);
        assert!(matches!(
            parse_responses("{\"image_id\": 1, \"detections\": []}", &reqs),
            Err(PluginError::Missing { image_id: 2 })
        ));
        assert!(matches!(parse_responses("not json", &reqs), Err(PluginError::BadLine { line: 1, .. })));
        let twice = "{\"image_id\": 1, \"detections\": []}\n{\"image_id\": 1, \"detections\": []}";
        assert!(matches!(parse_responses(twice, &reqs), Err(PluginError::BadLine { line: 2, .. })));
        assert!(matches!(
            parse_responses("{\"image_id\": 5, \"detections\": []}", &reqs),
            Err(PluginError::BadLine { line: 1, .. })
        ));
    }

    #[test]
    fn missing_program_is_a_spawn_error() {
        assert!(matches!(run("/nonexistent/detector", &[], &[req(1)]), Err(PluginError::Spawn { .. })));
    }
}
