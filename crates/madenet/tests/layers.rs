//! The folder layout is the architecture (ARCHITECTURE.md, "Folders"): a crate under
//! `crates/<layer>/` depends (normal dependencies) only on crates of its own layer or of the
//! layers above it, in the order core → outputs → planners → drivers → the binary → dev.

use std::path::{Path, PathBuf};

const LAYERS: [&str; 6] = ["core", "outputs", "planners", "drivers", "madenet", "dev"];

/// Every workspace crate: (package name, layer index, its madenet-* normal dependencies).
fn crates(root: &Path) -> Vec<(String, usize, Vec<String>)> {
    let mut manifests: Vec<(PathBuf, usize)> = vec![(root.join("crates/madenet/Cargo.toml"), 4)];
    for (k, layer) in LAYERS.iter().enumerate().filter(|(_, l)| **l != "madenet") {
        let dir = root.join("crates").join(layer);
        for e in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let m = e.unwrap().path().join("Cargo.toml");
            if m.exists() {
                manifests.push((m, k));
            }
        }
    }
    manifests
        .into_iter()
        .map(|(m, k)| {
            let doc: toml::Table = madenet_testkit::read(&m).parse().unwrap();
            let name = doc["package"]["name"].as_str().unwrap().to_string();
            let deps = doc
                .get("dependencies")
                .and_then(|d| d.as_table())
                .map(|d| {
                    d.keys()
                        .filter(|n| n.starts_with("madenet") && *n != "madenet-workspace-hack")
                        .cloned()
                        .collect()
                })
                .unwrap_or_default();
            (name, k, deps)
        })
        .collect()
}

#[test]
fn no_crate_depends_on_a_lower_layer() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let all = crates(&root);
    assert!(all.len() >= 20, "found {} crates", all.len());
    let layer_of = |n: &str| all.iter().find(|c| c.0 == n).map(|c| c.1);
    let mut up = Vec::new();
    for (name, k, deps) in &all {
        for d in deps {
            let dk = layer_of(d).unwrap_or_else(|| panic!("{name} depends on unknown {d}"));
            if dk > *k {
                up.push(format!("{name} ({}) → {d} ({})", LAYERS[*k], LAYERS[dk]));
            }
        }
    }
    assert!(up.is_empty(), "dependencies on a lower layer: {up:?}");
}
