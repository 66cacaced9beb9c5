//! Seeded mutation fuzzing of capture.json, .avatar and meta-model files, in process. Each
//! mutant is loaded under catch_unwind; a refusal must name the file, an accepted mutant must
//! also go through the next stage (posing, the networks) without a panic; the file is never
//! changed and no temporary file is left. Mutations: bit flips, random bytes, truncation,
//! deleted and duplicated ranges, numbers in the JSON (or the JSON header of a weights file)
//! replaced by extreme values, weights overwritten with NaN, infinity or 1e30.

use super::fixtures::*;
use super::snapshot;
use avatar_core::body::BodyParams;
use avatar_core::canonical::FieldCache;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

/// SplitMix64: a seeded generator with no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const EXTREMES: &[&str] = &[
    "1e30",
    "-1e30",
    "0",
    "-1",
    "1e-30",
    "null",
    "4096",
    "1000000",
    "65536",
    "-0.0",
    "18446744073709551616",
    "3.5e38",
    "\"x\"",
    "[]",
    "{}",
    "true",
    "0.5",
    "72",
    "1e308",
];

/// Byte ranges of the numbers in a JSON text.
/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        if c.is_ascii_digit() || (c == b'-' && text.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let start = i;
            while i < text.len()
                && matches!(text[i], b'0'..=b'9' | b'-' | b'+' | b'.' | b'e' | b'E')
            {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

fn mutate_json(rng: &mut Rng, text: &[u8]) -> Vec<u8> {
    let nums = numbers(text);
    if nums.is_empty() {
        return text.to_vec();
    }
    let (a, b) = nums[rng.below(nums.len())];
    let mut out = text[..a].to_vec();
    out.extend(EXTREMES[rng.below(EXTREMES.len())].as_bytes());
    out.extend(&text[b..]);
    out
}

fn mutate_bytes(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let mut b = b.to_vec();
    let n = b.len().max(1);
    match rng.below(5) {
        0 => {
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(n);
                if i < b.len() {
                    b[i] ^= 1 << rng.below(8);
                }
            }
        }
        1 => {
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(n);
                if i < b.len() {
                    b[i] = rng.next() as u8;
                }
            }
        }
        2 => b.truncate(rng.below(n)),
        3 => {
            let i = rng.below(n);
            let len = 1 + rng.below(64);
            b.drain(i.min(b.len())..(i + len).min(b.len()));
        }
        _ => {
            let i = rng.below(n);
            let piece: Vec<u8> = b[i.min(b.len())..(i + 1 + rng.below(64)).min(b.len())].to_vec();
            let at = rng.below(n).min(b.len());
            b.splice(at..at, piece);
        }
    }
    b
}

/// A weights file: mutate its JSON header (keeping the length field right), a weight, or bytes.
fn mutate_weights(rng: &mut Rng, b: &[u8]) -> Vec<u8> {
    let len = u64::from_le_bytes(b[8..16].try_into().unwrap()) as usize;
    match rng.below(3) {
        0 => {
            let header = mutate_json(rng, &b[16..16 + len]);
            let mut out = b[..8].to_vec();
            out.extend((header.len() as u64).to_le_bytes());
            out.extend(&header);
            out.extend(&b[16 + len..]);
            out
        }
        1 => {
            let mut out = b.to_vec();
            let weights = (b.len() - 16 - len) / 4;
            let at = 16 + len + 4 * rng.below(weights);
            let v =
                [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30, 0.0, 1e-38][rng.below(7)];
            out[at..at + 4].copy_from_slice(&v.to_le_bytes());
            out
        }
        _ => mutate_bytes(rng, b),
    }
}

struct Tally {
    kind: &'static str,
    refused: usize,
    accepted: usize,
    failures: Vec<String>,
}

impl Tally {
    fn new(kind: &'static str) -> Tally {
        Tally { kind, refused: 0, accepted: 0, failures: Vec::new() }
    }

    /// Load `path` with `load` (which also exercises an accepted file) and check the contract.
    fn check(
        &mut self,
        case: usize,
        path: &Path,
        watch: &Path,
        load: &dyn Fn(&Path) -> Result<(), String>,
    ) {
        let before = snapshot(watch);
        match catch_unwind(AssertUnwindSafe(|| load(path))) {
            Err(_) => self.failures.push(format!("{} case {case}: panic", self.kind)),
            Ok(Ok(())) => self.accepted += 1,
            Ok(Err(e)) => {
                self.refused += 1;
                if !e.contains(&*path.file_name().unwrap().to_string_lossy())
                    && !e.contains(&*watch.to_string_lossy())
                {
                    self.failures
                        .push(format!("{} case {case}: the error names no file: {e}", self.kind));
                }
            }
        }
        if snapshot(watch) != before {
            self.failures
                .push(format!("{} case {case}: a file changed or was left behind", self.kind));
        }
    }
}

pub fn run(cases: usize, seed: u64) {
    let dir = tempfile::tempdir().unwrap();
    let t = std::time::Instant::now();
    // One-frame capture: a mutant that stays valid is opened for real (back-projection and all).
    let cap = dir.path().join("cap");
    write_capture(&cap, 1);
    let manifest = std::fs::read(cap.join("capture.json")).unwrap();
    let avatars = [
        (dir.path().join("s.avatar"), static_header_bytes()),
        (dir.path().join("m.avatar"), meta_header_bytes()),
    ];
    let model_path = dir.path().join("model.bin");
    let (c, d) = (small_config(), avatar_neural::cpu_device());
    let siren = c.siren.init(1, &d);
    avatar_neural::MetaModel::from_parts(
        c,
        &c.init(siren.clone(), 1, &d),
        &siren,
        "fuzz base".into(),
    )
    .save(&model_path)
    .unwrap();
    let model = std::fs::read(&model_path).unwrap();
    let mut rng = Rng(seed);
    let mut tallies = [Tally::new("capture.json"), Tally::new(".avatar"), Tally::new("meta-model")];

    let open_capture = |p: &Path| {
        avatar_core::capture::Capture::open(p.parent().unwrap())
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    for case in 0..cases {
        let text = if rng.below(2) == 0 {
            mutate_json(&mut rng, &manifest)
        } else {
            mutate_bytes(&mut rng, &manifest)
        };
        let p = cap.join("capture.json");
        std::fs::write(&p, &text).unwrap();
        tallies[0].check(case, &p, &cap, &open_capture);
    }

    let pose = |p: &Path| -> Result<(), String> {
        let mut a = avatar_neural::AnyAvatar::load(p, &field_cache()).map_err(|e| e.to_string())?;
        a.set_mesh_resolution(avatar_neural::avatar::MeshResolution::new(16).unwrap());
        // An accepted mutant must pose without a panic (an error is fine: the CLI names the file).
        let _ = a.source().canonical_mesh(&BodyParams::default());
        Ok(())
    };
    let avatar_dir = dir.path().join("avatars");
    std::fs::create_dir_all(&avatar_dir).unwrap();
    for case in 0..cases {
        let (name, base) = &avatars[case % 2];
        let p = avatar_dir.join(name.file_name().unwrap());
        std::fs::write(&p, mutate_weights(&mut rng, base)).unwrap();
        tallies[1].check(case, &p, &avatar_dir, &pose);
        std::fs::remove_file(&p).unwrap();
    }

    let networks = |p: &Path| -> Result<(), String> {
        let m = avatar_neural::MetaModel::load(p).map_err(|e| e.to_string())?;
        let _ = (m.hyper_net(), m.static_siren());
        Ok(())
    };
    let model_dir = dir.path().join("models");
    std::fs::create_dir_all(&model_dir).unwrap();
    for case in 0..cases {
        let p = model_dir.join("model.bin");
        std::fs::write(&p, mutate_weights(&mut rng, &model)).unwrap();
        tallies[2].check(case, &p, &model_dir, &networks);
        std::fs::remove_file(&p).unwrap();
    }

    let failures: Vec<&String> = tallies.iter().flat_map(|t| &t.failures).collect();
    for t in &tallies {
        println!(
            "fuzz {}: {cases} mutants, {} refused naming the file, {} accepted (still valid), {} failures",
            t.kind,
            t.refused,
            t.accepted,
            t.failures.len()
        );
    }
    println!("fuzz: seed {seed}, {:.1} s", t.elapsed().as_secs_f64());
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.iter().map(|s| s.as_str()).collect::<Vec<_>>().join("\n")
    );
}

fn static_header_bytes() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.avatar");
    avatar_neural::model::weights_file::write(&p, &static_header(), &static_weights()).unwrap();
    std::fs::read(p).unwrap()
}

fn meta_header_bytes() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.avatar");
    avatar_neural::model::weights_file::write(&p, &meta_header(), &meta_weights()).unwrap();
    std::fs::read(p).unwrap()
}
