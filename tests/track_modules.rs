//! The structure of `src/track` (issue 9): no import cycle between its modules, and no file
//! over ~800 lines. A module depends on a sibling when it names it in a `use` or a path
//! (`super::lifecycle::Track`, `crate::track::config::Config`), or names an item the parent
//! `mod.rs` re-exports from it (`super::Config` is `config`'s). `offline/` counts as one
//! module. Comments and doc links are not dependencies.
// A native suite (`cargo test`); for wasm32 (`wasm-pack test --node`) it compiles to nothing:
// the wasm suites are the `wasm_*` and `*_wasm` files.
#![cfg(not(target_arch = "wasm32"))]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Longest file allowed in src/track (lines).
const MAX_LINES: usize = 820;

fn track_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src/track")
}

/// Source without comments (line comments and doc comments; block comments are not used).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Identifiers following `prefix` in `text` (`super::` → `lifecycle`, `{a, b}` → both).
fn names_after(text: &str, prefix: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(prefix) {
        rest = &rest[i + prefix.len()..];
        let tail = rest.trim_start();
        if let Some(group) = tail.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for part in group[..end].split(',') {
                let id: String = part
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !id.is_empty() {
                    out.push(id);
                }
            }
        } else {
            let id: String = tail
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !id.is_empty() {
                out.push(id);
            }
        }
    }
    out
}

/// The modules of src/track (file stems, `offline` for the folder) and the item → module
/// map of the parent's re-exports.
fn modules() -> (BTreeMap<String, Vec<PathBuf>>, BTreeMap<String, String>) {
    let dir = track_dir();
    let mut mods: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            let files = std::fs::read_dir(&p)
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|f| f.extension().is_some_and(|x| x == "rs"))
                .collect();
            mods.insert(name, files);
        } else if p.extension().is_some_and(|x| x == "rs") && !p.ends_with("mod.rs") {
            let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
            mods.insert(stem, vec![p]);
        }
    }
    // `pub use module::{Item, ...};` in mod.rs.
    let parent = code(&std::fs::read_to_string(dir.join("mod.rs")).unwrap());
    let mut reexports = BTreeMap::new();
    for stmt in parent.split(';') {
        let s = stmt.trim();
        let Some(rest) = s.strip_prefix("pub use ") else {
            continue;
        };
        let Some((module, items)) = rest.split_once("::") else {
            continue;
        };
        if !mods.contains_key(module) {
            continue;
        }
        for item in names_after(&format!("::{items}"), "::") {
            reexports.insert(item, module.to_string());
        }
    }
    (mods, reexports)
}

/// Sibling modules `name` (with its files) depends on.
fn dependencies(
    name: &str,
    files: &[PathBuf],
    mods: &BTreeMap<String, Vec<PathBuf>>,
    reexports: &BTreeMap<String, String>,
) -> BTreeSet<String> {
    let mut deps = BTreeSet::new();
    for f in files {
        let text = code(&std::fs::read_to_string(f).unwrap());
        let nested = f.parent() != Some(track_dir().as_path());
        // From offline/*.rs, `super::` is offline itself and `super::super::` is track.
        let prefixes: &[&str] = if nested {
            &["super::super::", "crate::track::"]
        } else {
            &["super::", "crate::track::"]
        };
        for prefix in prefixes {
            for id in names_after(&text, prefix) {
                let target = if mods.contains_key(&id) {
                    Some(id)
                } else {
                    reexports.get(&id).cloned()
                };
                if let Some(t) = target.filter(|t| t != name) {
                    deps.insert(t);
                }
            }
        }
    }
    deps
}

fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for m in graph.get(n).into_iter().flatten() {
            match state.get(m.as_str()).copied().unwrap_or(0) {
                1 => {
                    let start = path.iter().position(|p| p == m).unwrap_or(0);
                    let mut cycle = path[start..].to_vec();
                    cycle.push(m.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(m, graph, state, path) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(n, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn track_modules_import_each_other_without_cycles() {
    let (mods, reexports) = modules();
    assert!(mods.contains_key("online") && mods.contains_key("lifecycle"));
    assert_eq!(reexports.get("Config").map(String::as_str), Some("config"));
    let graph: BTreeMap<String, BTreeSet<String>> = mods
        .iter()
        .map(|(n, f)| (n.clone(), dependencies(n, f, &mods, &reexports)))
        .collect();
    // The checker itself sees real edges (it would pass vacuously otherwise).
    assert!(graph["online"].contains("lifecycle"), "{graph:?}");
    assert!(graph["offline"].contains("online") || graph["offline"].contains("config"));
    if let Some(c) = find_cycle(&graph) {
        panic!("import cycle in src/track: {}", c.join(" → "));
    }
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let g = |edges: &[(&str, &str)]| {
        let mut m: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in edges {
            m.entry(a.to_string()).or_default().insert(b.to_string());
            m.entry(b.to_string()).or_default();
        }
        m
    };
    assert!(find_cycle(&g(&[("a", "b"), ("b", "c")])).is_none());
    let c = find_cycle(&g(&[("a", "b"), ("b", "c"), ("c", "a")])).unwrap();
    assert_eq!(c.first(), c.last());
    assert_eq!(c.len(), 4);
    assert_eq!(
        names_after("use super::{a, b::C};\nsuper::x::y", "super::"),
        ["a", "b", "x"]
    );
}

#[test]
fn no_track_file_is_too_long() {
    fn walk(dir: &Path, out: &mut Vec<(PathBuf, usize)>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let n = std::fs::read_to_string(&p).unwrap().lines().count();
                out.push((p, n));
            }
        }
    }
    let mut files = Vec::new();
    walk(&track_dir(), &mut files);
    assert!(files.len() > 10);
    let long: Vec<_> = files.iter().filter(|(_, n)| *n > MAX_LINES).collect();
    assert!(long.is_empty(), "files over {MAX_LINES} lines: {long:?}");
}
