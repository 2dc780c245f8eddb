//! Every parser of user input, fed arbitrary bytes and mutated valid files: each returns a value
//! or an error that says where the problem is (the file, its line, or the field), and none
//! panics. 10,000 cases per parser and kind of input.
//!
//! The mutations are those a hand-edited file suffers: bytes replaced, inserted and deleted,
//! lines deleted and duplicated, digits changed, numbers negated.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use scene_gen::calibration::emva::parse_descriptor;
use scene_gen::calibration::ptc::parse_ptc;
use scene_gen::camera_spec::CameraSpec;
use scene_gen::library::LibraryFile;
use scene_gen::library::furniture::parse_furniture;
use scene_gen::library::rooms::parse_room_types;
use scene_gen::optimize::config::OptimizeConfig;
use scene_gen::path;
use scene_gen::sensor::Catalog;
use scene_gen::serve::{ServeDefaults, parse_request, respond};

const CASES: u32 = 10_000;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn read(path: &str) -> Vec<u8> {
    std::fs::read(repo(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// One edit of a byte string.
#[derive(Clone, Debug)]
enum Edit {
    Replace(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    DeleteLine(usize),
    DuplicateLine(usize),
    /// Replaces the digit at or after the position by another.
    Digit(usize, u8),
    /// Puts a minus sign before the number at or after the position.
    Negate(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    let at = 0usize..1 << 20;
    prop_oneof![
        (at.clone(), any::<u8>()).prop_map(|(i, b)| Edit::Replace(i, b)),
        (at.clone(), prop::sample::select(b" =,.-[]{}\"'\n\t#:0123456789eE".to_vec()))
            .prop_map(|(i, b)| Edit::Insert(i, b)),
        at.clone().prop_map(Edit::Delete),
        at.clone().prop_map(Edit::DeleteLine),
        at.clone().prop_map(Edit::DuplicateLine),
        (at.clone(), 0u8..10).prop_map(|(i, d)| Edit::Digit(i, d)),
        at.prop_map(Edit::Negate),
    ]
}

fn apply(bytes: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for e in edits {
        let n = b.len().max(1);
        let line_span = |b: &[u8], i: usize| {
            let start = b[..i].iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1);
            let end = b[i..].iter().position(|&c| c == b'\n').map_or(b.len(), |p| i + p + 1);
            (start, end)
        };
        match *e {
            Edit::Replace(i, v) if !b.is_empty() => b[i % n] = v,
            Edit::Insert(i, v) => b.insert(i % (b.len() + 1), v),
            Edit::Delete(i) if !b.is_empty() => {
                b.remove(i % n);
            }
            Edit::DeleteLine(i) if !b.is_empty() => {
                let (s, t) = line_span(&b, i % n);
                b.drain(s..t);
            }
            Edit::DuplicateLine(i) if !b.is_empty() => {
                let (s, t) = line_span(&b, i % n);
                let line = b[s..t].to_vec();
                b.splice(t..t, line);
            }
            Edit::Digit(i, d) => {
                if let Some(p) = b.iter().skip(i % n).position(u8::is_ascii_digit) {
                    b[i % n + p] = b'0' + d;
                }
            }
            Edit::Negate(i) => {
                if let Some(p) = b.iter().skip(i % n).position(u8::is_ascii_digit) {
                    b.insert(i % n + p, b'-');
                }
            }
            _ => {}
        }
    }
    b
}

/// Mutated copies of the seed files: (which seed, edits).
fn mutated(seeds: usize) -> impl Strategy<Value = (usize, Vec<Edit>)> {
    (0..seeds, prop::collection::vec(edit(), 1..6))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: CASES, failure_persistence: None, ..ProptestConfig::default() }
}

// ---- room types (rooms/*.toml) ----

const ROOMS: [&str; 5] =
    ["rooms/bathroom.toml", "rooms/bedroom.toml", "rooms/kitchen.toml", "rooms/living_room.toml", "rooms/office.toml"];

fn check_rooms(bytes: Vec<u8>) -> Result<(), TestCaseError> {
    let file = LibraryFile { path: PathBuf::from("rooms/fuzzed.toml"), bytes };
    if let Err(e) = parse_room_types(&[file]) {
        let msg = e.to_string();
        prop_assert!(msg.contains("rooms/fuzzed.toml"), "no file in: {msg}");
    }
    Ok(())
}

// ---- furniture (<class>/<class>.toml with generators, or with OBJ/MTL assets) ----

/// The embedded library (generators) and the OBJ sample library.
const FURNITURE_ROOTS: [&str; 2] = ["furniture", "examples/furniture_obj"];

/// The files of one furniture class folder of the OBJ sample library, as the library reads them.
fn furniture_class(class: &str) -> Vec<LibraryFile> {
    class_files(FURNITURE_ROOTS[1], class)
}

/// The files of `root/<class>`, named `furniture/<class>/...`.
fn class_files(root: &str, class: &str) -> Vec<LibraryFile> {
    let dir = repo(&format!("{root}/{class}"));
    let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    names.sort();
    names
        .into_iter()
        .map(|n| {
            let rel = PathBuf::from(format!("furniture/{class}/{}", n.to_string_lossy()));
            LibraryFile { bytes: std::fs::read(dir.join(&n)).unwrap(), path: rel }
        })
        .collect()
}

const CLASSES: [&str; 3] = ["sofa", "table", "plant"];

/// The class folder with its file number `which` (of the given extension) replaced by `bytes`.
fn check_furniture(root: &str, class: &str, ext: &str, which: usize, edits: &[Edit]) -> Result<(), TestCaseError> {
    let mut files = class_files(root, class);
    let targets: Vec<usize> =
        (0..files.len()).filter(|&i| files[i].path.extension().is_some_and(|e| e == ext)).collect();
    let target = targets[which % targets.len()];
    files[target].bytes = apply(&files[target].bytes, edits);
    if let Err(e) = parse_furniture(&files) {
        let msg = e.to_string();
        prop_assert!(msg.contains(&format!("furniture/{class}/")), "no file in: {msg}");
    }
    Ok(())
}

// ---- camera specs (inline and TOML) ----

const INLINE_SPECS: [&str; 4] = [
    "IMX174,focal_mm=4,pitch_deg=-10",
    "IMX172,focal_mm=6,f_number=2.8,noise=affine,max_width_px=320",
    "MT9V032,focal_mm=2.1,height_m=0.7,defocus=true,focus_m=1.5,motion_blur=true",
    "IMX250,exposure_s=0.01,gain_day_db=3,gain_night_db=18,vignetting=false",
];

const TOML_SPEC: &str = "sensor = \"IMX174\"\nfocal_mm = 4.0\nf_number = 2.0\npitch_deg = -10.0\nheight_m = 0.8\n\
                         exposure_s = 0.02\nnoise = \"emva\"\nmax_width_px = 320\n";

/// A spec is usable or refused with its field or sensor named.
fn check_spec(
    parsed: Result<CameraSpec, scene_gen::camera_spec::SpecError>,
    file: Option<&str>,
) -> Result<(), TestCaseError> {
    let checked = parsed.and_then(|spec| {
        spec.validate()?;
        spec.resolve(&Catalog::embedded()).map(|_| ())
    });
    if let Err(e) = checked {
        let msg = e.to_string();
        let located = msg.starts_with("camera spec field ")
            || msg.starts_with("unknown sensor '")
            || file.is_some_and(|f| msg.contains(f));
        prop_assert!(located, "not located: {msg}");
    }
    Ok(())
}

// ---- EMVA 1288 descriptors and photon-transfer CSVs ----

const PTC: &str = "# a photon-transfer measurement at two gains\n\
                   gain_db,exposure_s,photons,mean_dn,temporal_var_dn2,dark_mean_dn,dark_var_dn2\n\
                   0,0.01,0,30.1,9.2,30.1,9.2\n0,0.01,1000,80.2,14.3,30.0,9.1\n0,0.01,2000,130.4,19.8,30.2,9.3\n\
                   0,0.01,4000,230.9,30.1,30.1,9.2\n6,0.01,1000,130.0,40.0,31.0,20.0\n";

// ---- optimize config ----

// ---- serve requests ----

const REQUESTS: [&str; 4] = [
    r#"{"id": 1, "op": "describe"}"#,
    r#"{"id": "a", "op": "evaluate", "camera": "IMX174,focal_mm=4", "seeds": "0..1", "frames": 3, "max_width": 64}"#,
    r#"{"id": 2, "op": "evaluate", "camera": {"sensor": "IMX172", "focal_mm": 6.0}, "seeds": [0, 1], "weights": {"ap50": 2.0}}"#,
    r#"{"id": 3, "camera": "MT9V032,pitch_deg=-5", "frames": 2}"#,
];

/// A request parses, or is refused with an answer that names its line; parsing never runs an
/// evaluation.
fn check_request(line: &str) -> Result<(), TestCaseError> {
    let defaults = ServeDefaults::default();
    let catalog = Catalog::embedded();
    if parse_request(line, &defaults, &catalog).is_err() {
        let answer = respond(line, 7, &defaults, &catalog).expect("an answer to a non-blank line");
        prop_assert!(!answer.ok);
        prop_assert!(answer.json.contains("\"line\":7"), "no line in: {}", answer.json);
    }
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn room_types_take_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        check_rooms(bytes)?;
    }

    #[test]
    fn room_types_take_mutated_files((seed, edits) in mutated(ROOMS.len())) {
        check_rooms(apply(&read(ROOMS[seed]), &edits))?;
    }

    #[test]
    fn furniture_tomls_take_mutated_files(class in 0..CLASSES.len(), edits in prop::collection::vec(edit(), 1..6)) {
        for root in FURNITURE_ROOTS {
            check_furniture(root, CLASSES[class], "toml", 0, &edits)?;
        }
    }

    #[test]
    fn furniture_tomls_take_any_bytes(class in 0..CLASSES.len(), bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut files = furniture_class(CLASSES[class]);
        let toml = files.iter().position(|f| f.path.extension().is_some_and(|e| e == "toml")).unwrap();
        files[toml].bytes = bytes;
        if let Err(e) = parse_furniture(&files) {
            prop_assert!(e.to_string().contains("furniture/"), "no file in: {}", e);
        }
    }

    #[test]
    fn obj_assets_take_mutated_files(class in 0..CLASSES.len(), which in 0usize..8, edits in prop::collection::vec(edit(), 1..6)) {
        check_furniture(FURNITURE_ROOTS[1], CLASSES[class], "obj", which, &edits)?;
    }

    #[test]
    fn obj_material_files_take_mutated_files(class in 0..CLASSES.len(), which in 0usize..8, edits in prop::collection::vec(edit(), 1..6)) {
        check_furniture(FURNITURE_ROOTS[1], CLASSES[class], "mtl", which, &edits)?;
    }

    #[test]
    fn inline_camera_specs_take_any_text(text in "[ -~]{0,80}") {
        check_spec(CameraSpec::from_inline(&text), None)?;
    }

    #[test]
    fn inline_camera_specs_take_mutated_specs((seed, edits) in mutated(INLINE_SPECS.len())) {
        let spec = text(&apply(INLINE_SPECS[seed].as_bytes(), &edits));
        check_spec(CameraSpec::from_inline(&spec), None)?;
    }

    #[test]
    fn toml_camera_specs_take_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        check_spec(CameraSpec::from_toml(&text(&bytes), Path::new("fuzzed_camera.toml")), Some("fuzzed_camera.toml"))?;
    }

    #[test]
    fn toml_camera_specs_take_mutated_files(edits in prop::collection::vec(edit(), 1..6)) {
        let spec = text(&apply(TOML_SPEC.as_bytes(), &edits));
        check_spec(CameraSpec::from_toml(&spec, Path::new("fuzzed_camera.toml")), Some("fuzzed_camera.toml"))?;
    }

    #[test]
    fn emva_descriptors_take_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        if let Err(e) = parse_descriptor(&text(&bytes), Path::new("fuzzed/EMVA1288_Data.txt")) {
            prop_assert!(e.to_string().contains("fuzzed/EMVA1288_Data.txt"), "no file in: {}", e);
        }
    }

    #[test]
    fn emva_descriptors_take_mutated_files(edits in prop::collection::vec(edit(), 1..6)) {
        let descriptor = read("data/emva1288-set003-crop/EMVA1288_Data.txt");
        if let Err(e) = parse_descriptor(&text(&apply(&descriptor, &edits)), Path::new("fuzzed/EMVA1288_Data.txt")) {
            prop_assert!(e.to_string().contains("fuzzed/EMVA1288_Data.txt"), "no file in: {}", e);
        }
    }

    #[test]
    fn photon_transfer_csvs_take_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        if let Err(e) = parse_ptc(&text(&bytes), Path::new("fuzzed.csv")) {
            prop_assert!(e.to_string().contains("fuzzed.csv"), "no file in: {}", e);
        }
    }

    #[test]
    fn photon_transfer_csvs_take_mutated_files(edits in prop::collection::vec(edit(), 1..6)) {
        if let Err(e) = parse_ptc(&text(&apply(PTC.as_bytes(), &edits)), Path::new("fuzzed.csv")) {
            prop_assert!(e.to_string().contains("fuzzed.csv"), "no file in: {}", e);
        }
    }

    #[test]
    fn optimize_configs_take_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        if let Err(e) = OptimizeConfig::from_toml(&text(&bytes), Path::new("fuzzed_optimize.toml")) {
            prop_assert!(e.to_string().contains("fuzzed_optimize.toml"), "no file in: {}", e);
        }
    }

    #[test]
    fn optimize_configs_take_mutated_files(edits in prop::collection::vec(edit(), 1..6)) {
        let shipped = read("optimize.toml");
        if let Err(e) = OptimizeConfig::from_toml(&text(&apply(&shipped, &edits)), Path::new("fuzzed_optimize.toml")) {
            prop_assert!(e.to_string().contains("fuzzed_optimize.toml"), "no file in: {}", e);
        }
    }

    #[test]
    fn camera_paths_take_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400), json in any::<bool>()) {
        check_path(&text(&bytes), json)?;
    }

    #[test]
    fn camera_paths_take_mutated_files((seed, edits) in mutated(PATHS.len())) {
        let (file, json) = PATHS[seed];
        check_path(&text(&apply(file.as_bytes(), &edits)), json)?;
    }

    #[test]
    fn serve_requests_take_any_text(line in "[ -~]{0,120}") {
        check_request(&line)?;
    }

    #[test]
    fn serve_requests_take_mutated_requests((seed, edits) in mutated(REQUESTS.len())) {
        let line = text(&apply(REQUESTS[seed].as_bytes(), &edits)).replace('\n', " ");
        check_request(&line)?;
    }
}

// ---- camera paths (render --poses) ----

const PATHS: [(&str, bool); 3] = [
    (
        r#"{"poses": [{"position": [1.2, 3.4, 0.8], "yaw_deg": 90.0, "time_s": 0.0},
          {"x": 1.5, "y": 3.4, "yaw_deg": 45, "pitch_deg": -10, "time_s": 0.25}]}"#,
        true,
    ),
    (r#"[{"x": 2, "y": 2, "z": 1.1, "yaw_deg": 0}]"#, true),
    ("# path\nx,y,z,yaw_deg,pitch_deg,time_s\n1.2,3.4,0.8,90,-10,0\n1.5,3.4,0.8,45,-10,0.25\n", false),
];

fn check_path(text: &str, json: bool) -> Result<(), TestCaseError> {
    let name = if json { "fuzzed/poses.json" } else { "fuzzed/poses.csv" };
    match path::parse(Path::new(name), text) {
        Ok(poses) => {
            prop_assert!(!poses.is_empty());
            for p in poses {
                prop_assert!(p.x_m.is_finite() && p.y_m.is_finite() && p.yaw_deg.is_finite() && p.time_s.is_finite());
            }
        }
        Err(e) => prop_assert!(e.to_string().starts_with(name), "no file in: {}", e),
    }
    Ok(())
}

/// The seeds are valid: the mutations start from files the parsers accept.
#[test]
fn the_seed_files_parse() {
    for path in ROOMS {
        parse_room_types(&[LibraryFile { path: PathBuf::from(path), bytes: read(path) }]).unwrap();
    }
    for class in CLASSES {
        for root in FURNITURE_ROOTS {
            parse_furniture(&class_files(root, class)).unwrap();
        }
    }
    for (file, json) in PATHS {
        path::parse(Path::new(if json { "p.json" } else { "p.csv" }), file).unwrap();
    }
    for spec in INLINE_SPECS {
        let spec = CameraSpec::from_inline(spec).unwrap();
        spec.validate().unwrap();
        spec.resolve(&Catalog::embedded()).unwrap();
    }
    CameraSpec::from_toml(TOML_SPEC, Path::new("camera.toml")).unwrap().resolve(&Catalog::embedded()).unwrap();
    parse_descriptor(&text(&read("data/emva1288-set003-crop/EMVA1288_Data.txt")), Path::new("d.txt")).unwrap();
    parse_ptc(PTC, Path::new("ptc.csv")).unwrap();
    OptimizeConfig::from_toml(&text(&read("optimize.toml")), Path::new("optimize.toml")).unwrap();
    let (defaults, catalog) = (ServeDefaults::default(), Catalog::embedded());
    for request in REQUESTS {
        parse_request(request, &defaults, &catalog).unwrap().unwrap();
    }
}
