//! A small Markdown report builder for `reparam demo` (`out/report.md`): sections, tables of
//! figures and links to pictures.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};

/// An in-memory Markdown document.
#[derive(Clone, Debug, Default)]
pub struct Report {
    text: String,
}

impl Report {
    /// A report with a top-level title.
    pub fn new(title: &str) -> Self {
        Report {
            text: format!("# {title}\n\n"),
        }
    }

    /// A `##` section heading.
    pub fn section(&mut self, title: &str) {
        let _ = write!(self.text, "## {title}\n\n");
    }

    /// A paragraph of text.
    pub fn paragraph(&mut self, text: &str) {
        let _ = write!(self.text, "{text}\n\n");
    }

    /// A table with a header row.
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>]) {
        let _ = writeln!(self.text, "| {} |", header.join(" | "));
        let _ = writeln!(self.text, "|{}", "---|".repeat(header.len()));
        for row in rows {
            let _ = writeln!(self.text, "| {} |", row.join(" | "));
        }
        self.text.push('\n');
    }

    /// An embedded picture (path relative to the report).
    pub fn image(&mut self, caption: &str, relative_path: &str) {
        let _ = write!(
            self.text,
            "![{caption}]({relative_path})\n\n*{caption}*\n\n"
        );
    }

    /// The Markdown text.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Write the report to `path`, creating its folder.
    pub fn save(&self, path: &Path) -> Result<()> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        std::fs::write(path, &self.text).map_err(|e| Error::io(path, e))
    }
}

/// Format a figure with `digits` significant digits (3.7e-7, 0.0123, 41.2, 12345).
pub fn sig(x: f64, digits: u32) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let magnitude = x.abs().log10().floor() as i32;
    if !(-3..6).contains(&magnitude) {
        return format!("{:.*e}", (digits - 1) as usize, x);
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    format!("{x:.decimals$}")
}
