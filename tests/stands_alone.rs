//! The repository stands alone: no source, guide, bench, test or script names a path outside
//! it (a development machine's folders, the project's private notes), and every file under
//! `reference_data/` that a guide or the README names exists in the clone.

use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The text files reparam ships: sources, shaders, guides, manifests, scripts.
fn shipped_text_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if matches!(
                p.extension().and_then(|x| x.to_str()),
                Some("rs" | "md" | "toml" | "wgsl" | "comp" | "glsl" | "py" | "m" | "json" | "sh")
            ) || p.file_name().is_some_and(|n| n == "run")
            {
                out.push(p);
            }
        }
    }
    let mut files = vec![root().join("README.md"), root().join("Cargo.toml")];
    for d in [
        "src",
        "gpu/src",
        "gpu/shaders",
        "gpu/tests",
        "benches",
        "tests",
        "tools",
        ".ci",
    ] {
        walk(&root().join(d), &mut files);
    }
    // The models' own READMEs (their authors' words) are not ours to edit.
    walk(&root().join("reference_data"), &mut files);
    files.retain(|p| {
        !p.starts_with(root().join("reference_data/models")) || p.ends_with("models/README.md")
    });
    files
}

/// The patterns that name a place outside a clone. Built from pieces so that this file does
/// not match itself.
fn outside_patterns() -> Vec<String> {
    let up = "..".to_string() + "/shared";
    let mut v = vec![
        up,
        format!("/{}/", "work"),
        format!("/{}/", "home"),
        format!("/tmp/{}.", "tmp"),
        format!("shared/{}", "notes"),
        format!("shared/{}", "seeds"),
        format!("shared/{}", "realdata"),
    ];
    for alg in ["bpm", "gridwarp", "unwarp", "maps", "skinsimp"] {
        v.push(format!("{}/{alg}.md", "notes"));
    }
    v
}

#[test]
fn no_shipped_file_names_a_path_outside_the_repository() {
    let patterns = outside_patterns();
    let mut found = Vec::new();
    for file in shipped_text_files() {
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue;
        };
        for (n, line) in text.lines().enumerate() {
            for p in &patterns {
                if line.contains(p.as_str()) {
                    found.push(format!("{}:{}: {p}", file.display(), n + 1));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "paths outside the repository:\n{}",
        found.join("\n")
    );
}

/// The pattern finder is not blind: a line naming the private notes is caught.
#[test]
fn the_outside_pattern_check_catches_a_notes_path() {
    let line = format!("restated in `..{}/{}/gridwarp.md`", "/shared", "notes");
    assert!(outside_patterns().iter().any(|p| line.contains(p.as_str())));
}

/// Every `reference_data/…` path named in the README and the guides (a model, a picture, a
/// vectors folder) exists.
#[test]
fn every_reference_data_path_named_in_the_guides_exists() {
    let mut missing = Vec::new();
    let guides = shipped_text_files()
        .into_iter()
        .filter(|p| p.extension().is_some_and(|x| x == "md"));
    for file in guides {
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(at) = rest.find("reference_data/") {
                let tail = &rest[at..];
                let end = tail
                    .find(|c: char| c.is_whitespace() || "`)'\"|,;:]".contains(c))
                    .unwrap_or(tail.len());
                let named = tail[..end].trim_end_matches('.');
                rest = &tail[end..];
                if named.contains(['*', '{', '<', '…']) || named == "reference_data/" {
                    continue;
                }
                if !root().join(named).exists() {
                    missing.push(format!("{}:{}: {named}", file.display(), n + 1));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "named but not shipped:\n{}",
        missing.join("\n")
    );
}
