//! No circles between files (issue #38): in each crate (`src/`, `gpu/src/`), the graph whose
//! edges are a file's `use crate::…`, `use super::…` and `use self::…` imports (outside its
//! `#[cfg(test)]` module), each path resolved to the file that defines the module it names,
//! has no cycle. Module roots (`lib.rs`, `mod.rs`) are left out: they declare and re-export
//! their children, so every child's `use super::Item` would otherwise close a loop with them.
//! A loop of leaf files (`crosscheck/sweep.rs` → `crosscheck/bpm.rs` → `crosscheck/run.rs` →
//! `crosscheck/sweep.rs`, as there was) is what this rejects: the second test builds one.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file below the crate root: `a/b.rs` and `a/b/mod.rs` → [a, b].
fn module_of(root: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(root).unwrap_or(file);
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap_or_default();
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" {
        parts.push(stem.to_string());
    }
    parts
}

/// The text of every `use …;` statement before the file's `#[cfg(test)]`.
fn use_statements(text: &str) -> Vec<String> {
    let body = text.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = Vec::new();
    let mut current: Option<String> = None;
    for line in body.lines() {
        let code = line.split("//").next().unwrap_or("").trim();
        if let Some(c) = current.as_mut() {
            c.push_str(code);
        } else if let Some(rest) = code
            .strip_prefix("pub use ")
            .or_else(|| code.strip_prefix("pub(crate) use "))
            .or_else(|| code.strip_prefix("pub(super) use "))
            .or_else(|| code.strip_prefix("use "))
        {
            current = Some(rest.to_string());
        }
        if current.as_ref().is_some_and(|c| c.contains(';')) {
            let c = current.take().unwrap_or_default();
            out.push(c.split(';').next().unwrap_or("").replace(' ', ""));
        }
    }
    out
}

/// The paths of a use tree: `a::{b, c::{d, e}}` → a::b, a::c::d, a::c::e.
fn flatten(tree: &str) -> Vec<Vec<String>> {
    fn split_top(s: &str) -> Vec<&str> {
        let (mut depth, mut start, mut out) = (0, 0, Vec::new());
        for (i, ch) in s.char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    out.push(&s[start..i]);
                    start = i + 1;
                }
                _ => {}
            }
        }
        out.push(&s[start..]);
        out.into_iter().filter(|p| !p.is_empty()).collect()
    }
    match tree.find('{') {
        None => vec![tree.split("::").map(|s| s.to_string()).collect()],
        Some(open) => {
            let prefix: Vec<String> = tree[..open]
                .trim_end_matches("::")
                .split("::")
                .filter(|s| !s.is_empty())
                .map(|s| s.to_string())
                .collect();
            let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
            split_top(inner)
                .into_iter()
                .flat_map(flatten)
                .map(|rest| prefix.iter().cloned().chain(rest).collect())
                .collect()
        }
    }
}

/// The file that defines the longest module prefix of `path` (absolute, from the crate root).
fn file_of(root: &Path, path: &[String]) -> PathBuf {
    for k in (1..=path.len()).rev() {
        let dir: PathBuf = path[..k].iter().collect();
        let file = root.join(&dir).with_extension("rs");
        if file.is_file() {
            return file;
        }
        let module = root.join(&dir).join("mod.rs");
        if module.is_file() {
            return module;
        }
    }
    root.join("lib.rs")
}

fn is_root(file: &Path) -> bool {
    matches!(
        file.file_name().and_then(|n| n.to_str()),
        Some("lib.rs" | "mod.rs" | "main.rs")
    )
}

/// File-level import edges of the crate rooted at `root` (module roots left out).
fn import_graph(root: &Path) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let mut files = Vec::new();
    rust_files(root, &mut files);
    let mut graph = BTreeMap::new();
    for file in files.iter().filter(|f| !is_root(f)) {
        let module = module_of(root, file);
        let text = fs::read_to_string(file).unwrap_or_default();
        let mut targets = BTreeSet::new();
        for statement in use_statements(&text) {
            for path in flatten(&statement) {
                let absolute: Vec<String> = match path.first().map(String::as_str) {
                    Some("crate") => path[1..].to_vec(),
                    Some("self") => module.iter().cloned().chain(path[1..].to_vec()).collect(),
                    Some("super") => {
                        let ups = path.iter().take_while(|s| *s == "super").count();
                        let keep = module.len().saturating_sub(ups);
                        module[..keep]
                            .iter()
                            .cloned()
                            .chain(path[ups..].to_vec())
                            .collect()
                    }
                    _ => continue,
                };
                let target = file_of(root, &absolute);
                if &target != file && !is_root(&target) {
                    targets.insert(target);
                }
            }
        }
        graph.insert(file.clone(), targets);
    }
    graph
}

/// One cycle of the graph, if it has one (depth-first search, files in order).
fn find_cycle(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Option<Vec<PathBuf>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        Open,
        Done,
    }
    fn visit(
        node: &PathBuf,
        graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>,
        marks: &mut BTreeMap<PathBuf, Mark>,
        stack: &mut Vec<PathBuf>,
    ) -> Option<Vec<PathBuf>> {
        match marks.get(node) {
            Some(Mark::Done) => return None,
            Some(Mark::Open) => {
                let at = stack.iter().position(|n| n == node).unwrap_or(0);
                return Some(stack[at..].to_vec());
            }
            None => {}
        }
        marks.insert(node.clone(), Mark::Open);
        stack.push(node.clone());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(cycle) = visit(next, graph, marks, stack) {
                return Some(cycle);
            }
        }
        stack.pop();
        marks.insert(node.clone(), Mark::Done);
        None
    }
    let mut marks = BTreeMap::new();
    graph
        .keys()
        .find_map(|n| visit(n, graph, &mut marks, &mut Vec::new()))
}

#[test]
fn no_file_imports_itself_through_others() {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    // At least this many edges (counted 2026-12-03: src 400+, gpu/src 11), so that a parser
    // that finds no imports cannot pass.
    for (root, least) in [(manifest.join("src"), 300), (manifest.join("gpu/src"), 8)] {
        let graph = import_graph(&root);
        let edges: usize = graph.values().map(BTreeSet::len).sum();
        assert!(
            edges >= least,
            "{}: only {edges} import edges",
            root.display()
        );
        if let Some(cycle) = find_cycle(&graph) {
            let names: Vec<String> = cycle
                .iter()
                .map(|p| p.strip_prefix(&root).unwrap_or(p).display().to_string())
                .collect();
            panic!(
                "{}: files import each other in a circle: {} → back to the first",
                root.display(),
                names.join(" → ")
            );
        }
    }
}

#[test]
fn a_circle_of_three_files_is_found() {
    // crosscheck's old loop in miniature: run imports sweep, sweep imports the rows of bpm,
    // bpm imports run; and, beside it, a file that only imports downwards.
    let root = std::env::temp_dir().join(format!("reparam_import_layers_{}", std::process::id()));
    let dir = root.join("crosscheck");
    fs::create_dir_all(&dir).expect("temp dir");
    let write = |name: &str, text: &str| fs::write(dir.join(name), text).expect("write");
    write(
        "mod.rs",
        "mod run;\nmod sweep;\nmod bpm;\npub struct Row;\n",
    );
    write(
        "run.rs",
        "use super::sweep::sweep_table;\nuse super::Row;\n",
    );
    write(
        "sweep.rs",
        "use super::{\n    bpm::{bpm_rows, BpmRow},\n    Row,\n};\n",
    );
    write(
        "bpm.rs",
        "use crate::crosscheck::run::run_rows; // the loop\n",
    );
    write("plot.rs", "use super::Row;\n");
    fs::write(root.join("lib.rs"), "pub mod crosscheck;\n").expect("write");
    let graph = import_graph(&root);
    let cycle = find_cycle(&graph).expect("the loop is found");
    let names: BTreeSet<String> = cycle
        .iter()
        .map(|p| {
            p.file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    let expected: BTreeSet<String> = ["run.rs", "sweep.rs", "bpm.rs"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(names, expected);
    // Cut the loop: bpm.rs imports nothing above it, and the graph has no cycle.
    write("bpm.rs", "use std::fmt;\n");
    assert!(find_cycle(&import_graph(&root)).is_none());
    // A test module's imports do not count.
    write(
        "bpm.rs",
        "#[cfg(test)]\nmod tests {\n    use super::super::run::run_rows;\n}\n",
    );
    assert!(find_cycle(&import_graph(&root)).is_none());
    let _ = fs::remove_dir_all(&root);
}
