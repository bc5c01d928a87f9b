//! Every relative link in the README, the guides (`src/**/*.md`), `benches/README.md` and the
//! other Markdown files of the repository points to a file that exists, and every `#fragment`
//! into a Markdown file names one of its headings (issue #38: links that work on a forge).
//! Rust paths are checked by `cargo doc` instead (`RUSTDOCFLAGS="-D warnings"` in `.ci/run`):
//! the guides write them as shortcut links (`` [`crate::twin`] ``), which a forge shows as text
//! and this test does not see.
//!
//! Pictures in a guide `src/<module>/README.md` must be `../../reference_data/pictures/…`: on a
//! forge that is the repository's folder, and rustdoc, which renders the guide at
//! `doc/reparam/<module>/index.html`, resolves the same path to `doc/reference_data/pictures/`,
//! where `.ci/run` copies the pictures after `cargo doc`.

use std::path::{Path, PathBuf};

/// One link of a Markdown text: its target as written and whether it is an image.
#[derive(Debug, PartialEq)]
struct Link {
    target: String,
    image: bool,
}

/// The inline links `[text](target)` and images `![alt](target)` of `text`, outside fenced code
/// blocks and inline code spans. A title (`(target "title")`) is dropped.
fn links(text: &str) -> Vec<Link> {
    let mut found = Vec::new();
    let mut in_fence = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            continue;
        }
        if in_fence || (line.starts_with("    ") && !line.trim_start().starts_with(['-', '|'])) {
            continue;
        }
        let line = without_code_spans(line);
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let image = rest[..at]
                .rfind('[')
                .is_some_and(|open| open > 0 && rest.as_bytes()[open - 1] == b'!');
            let after = &rest[at + 2..];
            let Some(close) = closing_paren(after) else {
                break;
            };
            let target = after[..close].split_whitespace().next().unwrap_or("");
            found.push(Link {
                target: target.to_string(),
                image,
            });
            rest = &after[close..];
        }
    }
    found
}

/// `line` with the contents of its inline code spans (`` `…` ``) removed.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut in_code = false;
    for c in line.chars() {
        if c == '`' {
            in_code = !in_code;
        } else if !in_code {
            out.push(c);
        }
    }
    out
}

/// The index of the `)` that closes a link target starting at `s[0]` (nested parentheses
/// balanced).
fn closing_paren(s: &str) -> Option<usize> {
    let mut depth = 0usize;
    for (i, c) in s.char_indices() {
        match c {
            '(' => depth += 1,
            ')' if depth == 0 => return Some(i),
            ')' => depth -= 1,
            _ => {}
        }
    }
    None
}

/// Whether a target is relative to the file (not a URL, not a fragment of the same file).
fn is_relative(target: &str) -> bool {
    !(target.is_empty()
        || target.starts_with('#')
        || target.contains("://")
        || target.starts_with("mailto:")
        || target.starts_with('/'))
}

/// The anchor a forge gives a heading: lower case, letters, digits, `-` and `_` kept, spaces
/// turned into `-`, everything else dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a Markdown text's headings (outside fenced code).
fn anchors(text: &str) -> Vec<String> {
    let mut in_fence = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
        } else if !in_fence && line.starts_with('#') {
            out.push(slug(line.trim_start_matches('#')));
        }
    }
    out
}

/// What is wrong with the links of `text`, a file in `dir`: one line per broken link.
fn broken_links(text: &str, dir: &Path) -> Vec<String> {
    let mut broken = Vec::new();
    for link in links(text) {
        if !is_relative(&link.target) {
            continue;
        }
        let (path, fragment) = match link.target.split_once('#') {
            Some((p, f)) => (p, Some(f)),
            None => (link.target.as_str(), None),
        };
        let file = dir.join(path);
        if !file.exists() {
            broken.push(format!(
                "{}: no such file ({})",
                link.target,
                file.display()
            ));
            continue;
        }
        if let (Some(fragment), Some("md")) = (fragment, file.extension().and_then(|e| e.to_str()))
        {
            let target_text = std::fs::read_to_string(&file).unwrap_or_default();
            if !anchors(&target_text).iter().any(|a| a == fragment) {
                broken.push(format!("{}: no heading #{fragment}", link.target));
            }
        }
    }
    broken
}

/// The Markdown files the test covers: the repository root's and every one under `src/`,
/// `benches/`, `reference_data/` and `tools/`.
fn documents(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "md"))
        .collect();
    files.sort();
    for dir in ["src", "benches", "reference_data", "tools"] {
        walk(&root.join(dir), &mut files);
    }
    files
}

#[test]
fn every_relative_link_in_the_readme_and_the_guides_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = documents(root);
    assert!(files.iter().any(|f| f.ends_with("README.md")));
    assert!(files.iter().any(|f| f.ends_with("src/bpm/README.md")));
    let mut broken = Vec::new();
    let mut checked = 0;
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        checked += links(&text)
            .iter()
            .filter(|l| is_relative(&l.target))
            .count();
        for b in broken_links(&text, file.parent().unwrap()) {
            broken.push(format!(
                "{}: {b}",
                file.strip_prefix(root).unwrap().display()
            ));
        }
    }
    assert!(checked > 20, "only {checked} relative links found");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_guides_pictures_resolve_in_rustdoc_too() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut wrong = Vec::new();
    for file in documents(root) {
        let relative = file.strip_prefix(root).unwrap();
        // A guide two levels down, rendered by rustdoc two levels below `doc/`.
        if relative.components().count() != 3 || !relative.starts_with("src") {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        for link in links(&text).into_iter().filter(|l| l.image) {
            if !link.target.starts_with("../../reference_data/pictures/") {
                wrong.push(format!("{}: {}", relative.display(), link.target));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "pictures outside ../../reference_data/pictures/:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn a_made_up_broken_link_is_reported() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = "See [the guide](src/bpm/README.md), [nothing](src/no_such_guide.md), \
                ![a picture](reference_data/pictures/missing.png), [a heading](README.md#no-such-heading), \
                [the web](https://example.com/x.md), [here](#anywhere) and `[code](not/a/link.md)`.\n\
                ```\n[fenced](not/a/link/either.md)\n```\n";
    let broken = broken_links(text, dir);
    assert_eq!(broken.len(), 3, "{broken:?}");
    assert!(broken[0].starts_with("src/no_such_guide.md"));
    assert!(broken[1].starts_with("reference_data/pictures/missing.png"));
    assert!(broken[2].contains("no heading #no-such-heading"));
    let good = "[two commands](README.md#two-commands), ![p](reference_data/pictures/bpm_cone_checker.png)";
    assert!(broken_links(good, dir).is_empty());
}

#[test]
fn links_and_slugs_are_read_as_a_forge_reads_them() {
    assert_eq!(
        links("a ![x](p.png \"title\") and [y](q.md#f) [z]"),
        vec![
            Link {
                target: "p.png".into(),
                image: true
            },
            Link {
                target: "q.md#f".into(),
                image: false
            }
        ]
    );
    assert_eq!(slug(" Limits on input"), "limits-on-input");
    assert_eq!(
        slug(" Cross-checking the GPU kernels: `reparam crosscheck`"),
        "cross-checking-the-gpu-kernels-reparam-crosscheck"
    );
}
