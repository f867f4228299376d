//! The shape of the source tree, checked: how long files are, which file
//! of a crate imports which, and which crate depends on which.
//!
//! A file *imports* another when its code names a path into it: `use
//! crate::a::b`, `super::x`, `self::y::z`, or a child module's item
//! (`use child::Item`). A module file contains its children, so a parent
//! naming its own child (`mod child; pub use child::Item`) is no import;
//! a child naming its parent is. Comments and string literals are not
//! code. Tests (`tests.rs`, anything under a `tests/` folder) are left
//! out: they are where a module is looked at from outside.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The longest a source file outside the tests may be, in lines.
pub const MAX_LINES: usize = 800;

/// The source files of a crate's `src/` folder, tests left out.
pub fn sources(src: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().to_string();
            if path.is_dir() {
                if name != "tests" {
                    dirs.push(path);
                }
            } else if name.ends_with(".rs") && name != "tests.rs" {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Every crate folder (a `Cargo.toml` beside a `src/`) under `root`,
/// `target/` and the separately built `fuzz/` left out.
pub fn crates(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut dirs = vec![root.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        if dir.join("Cargo.toml").is_file() && dir.join("src").is_dir() {
            out.push(dir.clone());
        }
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().to_string();
            let skip = name.starts_with('.')
                || ["target", "fuzz", "node_modules"].contains(&name.as_str());
            if entry.path().is_dir() && !skip {
                dirs.push(entry.path());
            }
        }
    }
    out.sort();
    out
}

/// `text` with comments and the insides of string and character literals
/// blanked, so that only code is left to read paths from.
pub fn code_only(text: &str) -> String {
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && b.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == '*' && b.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if c == 'r' && (next == Some('"') || next == Some('#')) && !prev_is_ident(&b, i) {
            // A raw string: r"…", r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == '"' && (0..hashes).all(|h| b.get(j + 1 + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c == '"' {
            i += 1;
            while i < b.len() && b[i] != '"' {
                if b[i] == '\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push_str("\"\"");
        } else if c == '\'' && b.get(i + 2) == Some(&'\'') {
            out.push_str("' '");
            i += 3;
        } else if c == '\'' && next == Some('\\') {
            // An escaped character literal: '\n', '\u{..}'.
            i += 2;
            while i < b.len() && b[i] != '\'' {
                i += 1;
            }
            i += 1;
            out.push_str("' '");
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn prev_is_ident(b: &[char], i: usize) -> bool {
    i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_')
}

/// The module path of `file` in the crate whose sources are in `src`:
/// `src/a/b.rs` and `src/a/b/mod.rs` are `["a", "b"]`, `src/lib.rs` is `[]`.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap_or(file);
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().to_string())
        .collect();
    if let Some(last) = parts.pop() {
        let stem = last.trim_end_matches(".rs").to_string();
        if !["mod", "lib", "main"].contains(&stem.as_str()) {
            parts.push(stem);
        }
    }
    parts
}

/// The file of module `path` (or of the deepest module it starts with);
/// the crate root for a path that names no module at all.
fn file_of(src: &Path, path: &[String]) -> Option<PathBuf> {
    let root = ["lib.rs", "main.rs"]
        .iter()
        .map(|n| src.join(n))
        .find(|p| p.is_file());
    let mut found = root;
    let mut dir = src.to_path_buf();
    for part in path {
        let flat = dir.join(format!("{part}.rs"));
        let nested = dir.join(part).join("mod.rs");
        if flat.is_file() {
            found = Some(flat);
        } else if nested.is_file() {
            found = Some(nested);
        } else {
            break;
        }
        dir = dir.join(part);
    }
    found
}

/// The paths a piece of code names, each split at `::`, starting with
/// `crate`, `super`, `self` or a plain `use` name; `{a, b::c}` groups are
/// spread out.
fn named_paths(code: &str) -> Vec<Vec<String>> {
    let chars: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let word_start = i;
        if chars[i].is_alphabetic() || chars[i] == '_' {
            if word_start > 0
                && (chars[word_start - 1].is_alphanumeric()
                    || chars[word_start - 1] == '_'
                    || chars[word_start - 1] == ':')
            {
                while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                    i += 1;
                }
                continue;
            }
            let mut j = i;
            while j < chars.len() && (chars[j].is_alphanumeric() || chars[j] == '_') {
                j += 1;
            }
            let word: String = chars[i..j].iter().collect();
            if ["crate", "super", "self"].contains(&word.as_str()) && chars.get(j) == Some(&':') {
                let (paths, end) = path_tail(&chars, j, vec![word]);
                out.extend(paths);
                i = end;
                continue;
            }
            if word == "use" {
                // `use child::Item` names a child module of this file.
                let mut k = j;
                while k < chars.len() && chars[k].is_whitespace() {
                    k += 1;
                }
                let mut e = k;
                while e < chars.len() && (chars[e].is_alphanumeric() || chars[e] == '_') {
                    e += 1;
                }
                let first: String = chars[k..e].iter().collect();
                if !first.is_empty()
                    && !["crate", "super", "self", "std", "core", "alloc"].contains(&first.as_str())
                    && chars.get(e) == Some(&':')
                {
                    let (paths, end) = path_tail(&chars, e, vec!["self".into(), first]);
                    out.extend(paths);
                    i = end;
                    continue;
                }
            }
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// Reads `::a::b`, `::{a, b::c}` after `head` starting at `at`.
fn path_tail(chars: &[char], mut at: usize, head: Vec<String>) -> (Vec<Vec<String>>, usize) {
    let mut path = head;
    loop {
        if chars.get(at) == Some(&':') && chars.get(at + 1) == Some(&':') {
            at += 2;
            while at < chars.len() && chars[at].is_whitespace() {
                at += 1;
            }
            if chars.get(at) == Some(&'{') {
                let mut depth = 0;
                let start = at + 1;
                let mut end = at;
                while end < chars.len() {
                    match chars[end] {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    end += 1;
                }
                let inner: String = chars[start..end.min(chars.len())].iter().collect();
                let mut out = Vec::new();
                for item in split_top(&inner) {
                    let item = item.trim();
                    let item = item.split(" as ").next().unwrap_or(item).trim();
                    if item.is_empty() || item == "*" {
                        out.push(path.clone());
                        continue;
                    }
                    let mut p = path.clone();
                    let ic: Vec<char> = format!("::{item}").chars().collect();
                    let (sub, _) = path_tail(&ic, 0, Vec::new());
                    for s in sub {
                        let mut q = p.clone();
                        q.extend(s);
                        out.push(q);
                    }
                    p.clear();
                }
                return (out, end + 1);
            }
            let mut e = at;
            while e < chars.len() && (chars[e].is_alphanumeric() || chars[e] == '_') {
                e += 1;
            }
            if e == at {
                return (vec![path], at);
            }
            path.push(chars[at..e].iter().collect());
            at = e;
        } else {
            return (vec![path], at);
        }
    }
}

fn split_top(s: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut depth = 0;
    for c in s.chars() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                out.push(String::new());
                continue;
            }
            _ => {}
        }
        if let Some(last) = out.last_mut() {
            last.push(c);
        }
    }
    out
}

/// Which file of the crate in `src` imports which (see the module's doc).
pub fn imports(src: &Path) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let mut graph = BTreeMap::new();
    for file in sources(src) {
        let text = std::fs::read_to_string(&file).unwrap_or_default();
        let code = code_only(&text);
        let here = module_of(src, &file);
        let name = file
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        // The folder that holds this module's children.
        let children = if ["lib.rs", "main.rs", "mod.rs"].contains(&name.as_str()) {
            file.parent().map(Path::to_path_buf).unwrap_or_default()
        } else {
            file.with_extension("")
        };
        let mut targets = BTreeSet::new();
        for path in named_paths(&code) {
            let (first, rest) = path
                .split_first()
                .map(|(f, r)| (f.as_str(), r))
                .unwrap_or(("", &[]));
            let mut full: Vec<String> = match first {
                "crate" => Vec::new(),
                "self" => here.clone(),
                "super" => here[..here.len().saturating_sub(1)].to_vec(),
                _ => continue,
            };
            let mut rest = rest;
            while first == "super" && rest.first().map(String::as_str) == Some("super") {
                full.pop();
                rest = &rest[1..];
            }
            full.extend(rest.iter().cloned());
            if let Some(target) = file_of(src, &full) {
                if target != file && !target.starts_with(&children) {
                    targets.insert(target);
                }
            }
        }
        graph.insert(file, targets);
    }
    graph
}

/// The groups of files that import each other, directly or through
/// others (strongly connected components of more than one file).
pub fn circles(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<Vec<PathBuf>> {
    // Tarjan's algorithm, iterative.
    let nodes: Vec<&PathBuf> = graph.keys().collect();
    let index_of: BTreeMap<&PathBuf, usize> =
        nodes.iter().enumerate().map(|(i, p)| (*p, i)).collect();
    let edges: Vec<Vec<usize>> = nodes
        .iter()
        .map(|p| {
            graph[*p]
                .iter()
                .filter_map(|t| index_of.get(t).copied())
                .collect()
        })
        .collect();
    let n = nodes.len();
    let (mut index, mut low, mut on) = (vec![usize::MAX; n], vec![0; n], vec![false; n]);
    let (mut stack, mut next, mut out) = (Vec::new(), 0, Vec::new());
    for start in 0..n {
        if index[start] != usize::MAX {
            continue;
        }
        let mut work = vec![(start, 0usize)];
        while let Some(&mut (v, ref mut k)) = work.last_mut() {
            if *k == 0 {
                index[v] = next;
                low[v] = next;
                next += 1;
                stack.push(v);
                on[v] = true;
            }
            if *k < edges[v].len() {
                let w = edges[v][*k];
                *k += 1;
                if index[w] == usize::MAX {
                    work.push((w, 0));
                } else if on[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(parent, _)) = work.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut group = Vec::new();
                while let Some(w) = stack.pop() {
                    on[w] = false;
                    group.push(nodes[w].clone());
                    if w == v {
                        break;
                    }
                }
                if group.len() > 1 {
                    group.sort();
                    out.push(group);
                }
            }
        }
    }
    out
}

/// The source files (tests left out) of every crate under `root` with
/// [`MAX_LINES`] lines or more, with their length.
pub fn long_files(root: &Path) -> Vec<(PathBuf, usize)> {
    let mut out = Vec::new();
    for krate in crates(root) {
        for file in sources(&krate.join("src")) {
            let lines = std::fs::read_to_string(&file)
                .map(|t| t.lines().count())
                .unwrap_or(0);
            if lines >= MAX_LINES {
                out.push((file, lines));
            }
        }
    }
    out
}

/// A workspace crate: its folder (relative to the workspace root) and the
/// workspace crates it depends on to build (not for its tests).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Crate {
    /// The folder, `services/hardware`.
    pub dir: String,
    /// The workspace crates it uses.
    pub uses: BTreeSet<String>,
}

/// The workspace's crates by name, from `cargo metadata` (no registry
/// needed: only the workspace's own manifests are read).
pub fn workspace(root: &Path) -> Result<BTreeMap<String, Crate>, String> {
    let meta = metadata(root)?;
    let packages = meta["packages"].as_array().cloned().unwrap_or_default();
    let names: BTreeSet<String> = packages
        .iter()
        .filter_map(|p| p["name"].as_str().map(String::from))
        .collect();
    let mut crates = BTreeMap::new();
    for p in &packages {
        let (Some(name), Some(manifest)) = (p["name"].as_str(), p["manifest_path"].as_str()) else {
            continue;
        };
        let dir = Path::new(manifest)
            .parent()
            .and_then(|d| d.strip_prefix(root).ok())
            .map(|d| d.to_string_lossy().to_string())
            .unwrap_or_default();
        let uses = p["dependencies"]
            .as_array()
            .into_iter()
            .flatten()
            .filter(|d| d["kind"].is_null())
            .filter_map(|d| d["name"].as_str())
            .filter(|d| names.contains(*d))
            .map(String::from)
            .collect();
        crates.insert(name.to_string(), Crate { dir, uses });
    }
    Ok(crates)
}

/// Where a workspace crate takes `zenoh` or `zenoh-ext` with their default
/// features, as `crate → dependency (kind)`, from `cargo metadata`'s
/// output. Zenoh's defaults are every transport it has (QUIC, UDP,
/// WebSocket, compression, several links): one crate that takes them, even
/// only for its tests, turns them on for every test build of the
/// workspace, which then compiles transports the project does not offer
/// (QUIC's quinn, the RSA of public-key authentication, and more).
pub fn zenoh_defaults(meta: &serde_json::Value) -> Vec<String> {
    let mut out = Vec::new();
    for p in meta["packages"].as_array().into_iter().flatten() {
        let name = p["name"].as_str().unwrap_or("?");
        for d in p["dependencies"].as_array().into_iter().flatten() {
            let dep = d["name"].as_str().unwrap_or("");
            if matches!(dep, "zenoh" | "zenoh-ext") && d["uses_default_features"] != false {
                let kind = d["kind"].as_str().unwrap_or("normal");
                out.push(format!("{name} → {dep} ({kind})"));
            }
        }
    }
    out
}

/// `cargo metadata` of the workspace's own manifests.
pub fn metadata(root: &Path) -> Result<serde_json::Value, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(root)
        .output()
        .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo metadata failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    serde_json::from_slice(&out.stdout).map_err(|e| format!("cargo metadata's output: {e}"))
}

/// Every workspace crate `name` needs to build, itself left out.
pub fn needs(crates: &BTreeMap<String, Crate>, name: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo: Vec<String> = crates
        .get(name)
        .map(|c| c.uses.iter().cloned().collect())
        .unwrap_or_default();
    while let Some(next) = todo.pop() {
        if seen.insert(next.clone()) {
            if let Some(c) = crates.get(&next) {
                todo.extend(c.uses.iter().cloned());
            }
        }
    }
    seen
}

/// The crates and their arrows as a Mermaid flowchart, each crate in a box
/// of its top-level folder; an arrow points from a crate to one it uses.
/// Arrows that another path already implies are left out, so the picture
/// stays readable.
pub fn mermaid(crates: &BTreeMap<String, Crate>) -> String {
    let id = |n: &str| n.replace('-', "_");
    let mut rooms: BTreeMap<String, Vec<&String>> = BTreeMap::new();
    for (name, c) in crates {
        let room = c.dir.split('/').next().unwrap_or("").to_string();
        rooms.entry(room).or_default().push(name);
    }
    let mut out = String::from("flowchart BT\n");
    for (room, names) in &rooms {
        out += &format!("  subgraph {room}[\"{room}/\"]\n");
        for n in names {
            out += &format!(
                "    {}[\"{n}<br/><small>{}</small>\"]\n",
                id(n),
                crates[*n].dir
            );
        }
        out += "  end\n";
    }
    for (name, c) in crates {
        for dep in &c.uses {
            let implied = c
                .uses
                .iter()
                .any(|other| other != dep && needs(crates, other).contains(dep));
            if !implied {
                out += &format!("  {} --> {}\n", id(name), id(dep));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
