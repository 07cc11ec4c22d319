//! No import circles inside core: each module's `crate::`, `super::` and `self::` paths (outside
//! comments and test modules) name the modules it depends on, and no chain of them leads back.
//! A child may use its parent and the parent its children (that is how a module is split), but
//! two siblings, or two modules anywhere, may not need each other: what they share goes in a
//! module below both (`kernels::requests`, `kernels::work_list`, `binary16`, `sequence`, …).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Module path (`kernels::apply`) of a source file under `src/`.
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .with_extension("")
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    parts
}

/// The source without comments and without a trailing `#[cfg(test)] mod tests { .. }`.
fn code_of(src: &str) -> String {
    let src = match src.find("#[cfg(test)]\nmod tests {") {
        Some(i) => &src[..i],
        None => src,
    };
    src.lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every path starting `crate::`, `super::` or `self::` in `code`, with `a::{b, c::d}` groups
/// expanded one level (as `a::b`, `a::c::d`).
fn paths_in(code: &str) -> Vec<String> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == ':';
    let mut out = Vec::new();
    for start in ["crate::", "super::", "self::"] {
        for (i, _) in code.match_indices(start) {
            if code[..i].ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_') {
                continue;
            }
            let rest = &code[i..];
            let end = rest.find(|c: char| !ident(c)).unwrap_or(rest.len());
            let path = rest[..end].trim_end_matches(':').to_string();
            if rest[end..].starts_with('{') && rest[..end].ends_with("::") {
                let group = &rest[end + 1..rest.find('}').unwrap_or(rest.len())];
                for item in group.split(',') {
                    let item = item.split_whitespace().next().unwrap_or("");
                    if !item.is_empty() && item != "self" {
                        out.push(format!("{path}::{item}"));
                    }
                }
            }
            out.push(path);
        }
    }
    out
}

/// The longest module named by `path` as seen from module `from`, if any.
fn resolve(from: &[String], path: &str, modules: &BTreeSet<Vec<String>>) -> Option<Vec<String>> {
    let mut parts: Vec<&str> = path.split("::").collect();
    let mut base: Vec<String> = match parts[0] {
        "crate" => Vec::new(),
        _ => from.to_vec(),
    };
    while let Some(&p) = parts.first() {
        match p {
            "crate" | "self" => {}
            "super" => {
                base.pop();
            }
            _ => break,
        }
        parts.remove(0);
    }
    (0..=parts.len()).rev().find_map(|n| {
        let mut m = base.clone();
        m.extend(parts[..n].iter().map(|s| s.to_string()));
        modules.contains(&m).then_some(m)
    })
}

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_module_of_core_imports_one_that_imports_it_back() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let modules: BTreeSet<Vec<String>> = files
        .iter()
        .map(|f| module_of(f.strip_prefix(&src).unwrap()))
        .collect();
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for file in &files {
        let from = module_of(file.strip_prefix(&src).unwrap());
        if from.last().is_some_and(|m| m == "tests") {
            continue;
        }
        let code = code_of(&std::fs::read_to_string(file).unwrap());
        for path in paths_in(&code) {
            let Some(to) = resolve(&from, &path, &modules) else {
                continue;
            };
            // A module and its ancestors or descendants are one module split up.
            if !(to.starts_with(&from) || from.starts_with(&to)) {
                edges.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    assert!(
        edges.len() > 20,
        "the scan found too few imports: {edges:?}"
    );
    // Depth-first search for a path back to each module.
    for start in edges.keys() {
        let mut stack = vec![vec![start.clone()]];
        let mut seen = BTreeSet::new();
        while let Some(chain) = stack.pop() {
            for next in edges.get(chain.last().unwrap()).into_iter().flatten() {
                let names = |c: &[Vec<String>]| c.iter().map(|m| m.join("::")).collect::<Vec<_>>();
                assert!(
                    next != start,
                    "import circle: {} -> {}",
                    names(&chain).join(" -> "),
                    start.join("::")
                );
                if seen.insert(next.clone()) {
                    let mut longer = chain.clone();
                    longer.push(next.clone());
                    stack.push(longer);
                }
            }
        }
    }
}
