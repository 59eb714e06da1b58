//! The core's modules depend one way: `world` → `scene` and `policies` → `scene`, with
//! `pipeline` above both joining them into a step. A law that reached into the world, or a
//! world that called a law, would tie the two back together; this test reads the sources and
//! fails on the first such import.

use std::fs;
use std::path::{Path, PathBuf};

fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// Every line of the modules under `dir` that names `crate::<forbidden>` (a `use` or a path),
/// comments aside.
fn reaches(dir: &str, forbidden: &str) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join(dir);
    let needle = format!("crate::{forbidden}");
    let mut found = Vec::new();
    for file in sources(&root) {
        for (k, line) in fs::read_to_string(&file).unwrap().lines().enumerate() {
            let code = line.split("//").next().unwrap();
            if code.contains(&needle) {
                found.push(format!("{}:{}: {}", file.display(), k + 1, line.trim()));
            }
        }
    }
    found
}

#[test]
fn the_laws_never_import_the_world() {
    assert_eq!(reaches("policies", "world"), Vec::<String>::new());
}

#[test]
fn the_world_never_calls_the_laws() {
    assert_eq!(reaches("world", "policies"), Vec::<String>::new());
}

#[test]
fn the_shared_types_import_neither() {
    assert_eq!(reaches("scene", "world"), Vec::<String>::new());
    assert_eq!(reaches("scene", "policies"), Vec::<String>::new());
}
