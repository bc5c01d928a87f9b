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
    /// Each cell's `|` is escaped (`\|`: a header such as `largest |uv|` would otherwise
    /// split its column and break the table in every Markdown viewer).
    pub fn table(&mut self, header: &[&str], rows: &[Vec<String>]) {
        let line = |cells: Vec<String>| format!("| {} |", cells.join(" | "));
        let escaped = |cell: &str| cell.replace('|', "\\|");
        let _ = writeln!(
            self.text,
            "{}",
            line(header.iter().map(|c| escaped(c)).collect())
        );
        let _ = writeln!(self.text, "|{}", "---|".repeat(header.len()));
        for row in rows {
            let _ = writeln!(
                self.text,
                "{}",
                line(row.iter().map(|c| escaped(c)).collect())
            );
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

/// The path (e.g. `results[0].training.rms_mean`) of the first NaN or infinite number in
/// `value` as serde serialises it, or `None` when every number is finite. serde_json writes
/// such numbers as `null`; the command line checks its `--json` output with this first
/// ([`crate::Error::NonFiniteOutput`]).
pub fn first_non_finite<T: serde::Serialize + ?Sized>(value: &T) -> Option<String> {
    let mut checker = finite::Checker::default();
    match value.serialize(&mut checker) {
        Err(finite::Stop::NonFinite(path)) => Some(path),
        _ => None,
    }
}

/// A serde serializer that writes nothing and stops at the first non-finite float.
mod finite {
    use std::fmt::{self, Display, Write as _};

    use serde::ser::{self, Serialize};

    #[derive(Default)]
    pub struct Checker {
        path: String,
    }

    #[derive(Debug)]
    pub enum Stop {
        /// The path of the non-finite number.
        NonFinite(String),
        /// A `Serialize` impl failed on its own (not our concern here).
        Other,
    }

    impl Display for Stop {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            match self {
                Stop::NonFinite(path) => write!(f, "{path} is not finite"),
                Stop::Other => f.write_str("serialisation failed"),
            }
        }
    }

    impl std::error::Error for Stop {}

    impl ser::Error for Stop {
        fn custom<T: Display>(_: T) -> Self {
            Stop::Other
        }
    }

    type R = Result<(), Stop>;

    impl Checker {
        fn float(&self, v: f64) -> R {
            if v.is_finite() {
                return Ok(());
            }
            let path = self.path.trim_start_matches('.');
            Err(Stop::NonFinite(if path.is_empty() {
                "the result".to_string()
            } else {
                path.to_string()
            }))
        }

        fn nested<T: Serialize + ?Sized>(&mut self, segment: fmt::Arguments, v: &T) -> R {
            let len = self.path.len();
            let _ = self.path.write_fmt(segment);
            let result = v.serialize(&mut *self);
            self.path.truncate(len);
            result
        }
    }

    pub struct Compound<'a> {
        checker: &'a mut Checker,
        index: usize,
        /// The path's length before this value (a variant name is added to it).
        len: usize,
    }

    impl Compound<'_> {
        fn element<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            let i = self.index;
            self.index += 1;
            self.checker.nested(format_args!("[{i}]"), v)
        }

        /// Restore the path to what it was before this value.
        fn finish(self) -> R {
            self.checker.path.truncate(self.len);
            Ok(())
        }
    }

    impl<'a> Checker {
        /// A compound value at the current path, with `.variant` added when it is an enum's.
        fn compound(&'a mut self, variant: Option<&str>) -> Compound<'a> {
            let len = self.path.len();
            if let Some(variant) = variant {
                let _ = write!(self.path, ".{variant}");
            }
            Compound {
                checker: self,
                index: 0,
                len,
            }
        }
    }

    impl<'a> ser::Serializer for &'a mut Checker {
        type Ok = ();
        type Error = Stop;
        type SerializeSeq = Compound<'a>;
        type SerializeTuple = Compound<'a>;
        type SerializeTupleStruct = Compound<'a>;
        type SerializeTupleVariant = Compound<'a>;
        type SerializeMap = Compound<'a>;
        type SerializeStruct = Compound<'a>;
        type SerializeStructVariant = Compound<'a>;

        fn serialize_bool(self, _: bool) -> R {
            Ok(())
        }
        fn serialize_i8(self, _: i8) -> R {
            Ok(())
        }
        fn serialize_i16(self, _: i16) -> R {
            Ok(())
        }
        fn serialize_i32(self, _: i32) -> R {
            Ok(())
        }
        fn serialize_i64(self, _: i64) -> R {
            Ok(())
        }
        fn serialize_u8(self, _: u8) -> R {
            Ok(())
        }
        fn serialize_u16(self, _: u16) -> R {
            Ok(())
        }
        fn serialize_u32(self, _: u32) -> R {
            Ok(())
        }
        fn serialize_u64(self, _: u64) -> R {
            Ok(())
        }
        fn serialize_f32(self, v: f32) -> R {
            self.float(v as f64)
        }
        fn serialize_f64(self, v: f64) -> R {
            self.float(v)
        }
        fn serialize_char(self, _: char) -> R {
            Ok(())
        }
        fn serialize_str(self, _: &str) -> R {
            Ok(())
        }
        fn serialize_bytes(self, _: &[u8]) -> R {
            Ok(())
        }
        fn serialize_none(self) -> R {
            Ok(())
        }
        fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> R {
            v.serialize(self)
        }
        fn serialize_unit(self) -> R {
            Ok(())
        }
        fn serialize_unit_struct(self, _: &'static str) -> R {
            Ok(())
        }
        fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> R {
            Ok(())
        }
        fn serialize_newtype_struct<T: Serialize + ?Sized>(self, _: &'static str, v: &T) -> R {
            v.serialize(self)
        }
        fn serialize_newtype_variant<T: Serialize + ?Sized>(
            self,
            _: &'static str,
            _: u32,
            variant: &'static str,
            v: &T,
        ) -> R {
            self.nested(format_args!(".{variant}"), v)
        }
        fn serialize_seq(self, _: Option<usize>) -> Result<Compound<'a>, Stop> {
            Ok(self.compound(None))
        }
        fn serialize_tuple(self, _: usize) -> Result<Compound<'a>, Stop> {
            self.serialize_seq(None)
        }
        fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, Stop> {
            self.serialize_seq(None)
        }
        fn serialize_tuple_variant(
            self,
            _: &'static str,
            _: u32,
            variant: &'static str,
            _: usize,
        ) -> Result<Compound<'a>, Stop> {
            Ok(self.compound(Some(variant)))
        }
        fn serialize_map(self, _: Option<usize>) -> Result<Compound<'a>, Stop> {
            self.serialize_seq(None)
        }
        fn serialize_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, Stop> {
            self.serialize_seq(None)
        }
        fn serialize_struct_variant(
            self,
            _: &'static str,
            _: u32,
            variant: &'static str,
            _: usize,
        ) -> Result<Compound<'a>, Stop> {
            Ok(self.compound(Some(variant)))
        }
    }

    /// The sequence-like compounds: each element numbered, `[i]`.
    macro_rules! numbered {
        ($($kind:ident :: $method:ident),*) => {$(
            impl ser::$kind for Compound<'_> {
                type Ok = ();
                type Error = Stop;
                fn $method<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
                    self.element(v)
                }
                fn end(self) -> R {
                    self.finish()
                }
            }
        )*};
    }
    numbered!(
        SerializeSeq::serialize_element,
        SerializeTuple::serialize_element,
        SerializeTupleStruct::serialize_field,
        SerializeTupleVariant::serialize_field
    );

    impl ser::SerializeMap for Compound<'_> {
        type Ok = ();
        type Error = Stop;
        fn serialize_key<T: Serialize + ?Sized>(&mut self, _: &T) -> R {
            Ok(())
        }
        fn serialize_value<T: Serialize + ?Sized>(&mut self, v: &T) -> R {
            self.element(v)
        }
        fn end(self) -> R {
            self.finish()
        }
    }

    /// The struct-like compounds: each field named, `.key`.
    macro_rules! named {
        ($($kind:ident),*) => {$(
            impl ser::$kind for Compound<'_> {
                type Ok = ();
                type Error = Stop;
                fn serialize_field<T: Serialize + ?Sized>(
                    &mut self,
                    key: &'static str,
                    v: &T,
                ) -> R {
                    self.checker.nested(format_args!(".{key}"), v)
                }
                fn end(self) -> R {
                    self.finish()
                }
            }
        )*};
    }
    named!(SerializeStruct, SerializeStructVariant);
}

#[cfg(test)]
mod tests {
    use super::first_non_finite;

    #[derive(serde::Serialize)]
    struct Inner {
        rms: f64,
        list: Vec<Option<f32>>,
    }

    #[derive(serde::Serialize)]
    struct Outer {
        name: &'static str,
        results: Vec<Inner>,
    }

    #[test]
    fn the_first_non_finite_number_is_found_by_its_path() {
        let ok = Outer {
            name: "x",
            results: vec![Inner {
                rms: 1.0,
                list: vec![None, Some(2.0)],
            }],
        };
        assert_eq!(first_non_finite(&ok), None);
        let bad = Outer {
            name: "x",
            results: vec![
                Inner {
                    rms: 1.0,
                    list: vec![],
                },
                Inner {
                    rms: 0.0,
                    list: vec![Some(1.0), Some(f32::INFINITY)],
                },
            ],
        };
        assert_eq!(
            first_non_finite(&bad).as_deref(),
            Some("results[1].list[1]")
        );
        assert_eq!(first_non_finite(&f64::NAN).as_deref(), Some("the result"));
    }
}

/// The tables of a Markdown `text`: per table, its rows split into cells at every `|` that is
/// not escaped (header and separator included). For tests of the reports: a table whose rows
/// have different cell counts does not render.
pub fn markdown_tables(text: &str) -> Vec<Vec<Vec<String>>> {
    let mut tables = Vec::new();
    let mut current: Vec<Vec<String>> = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        if line.starts_with('|') && line.ends_with('|') {
            let mut cells = Vec::new();
            let mut cell = String::new();
            let mut chars = line[1..line.len() - 1].chars().peekable();
            while let Some(c) = chars.next() {
                match c {
                    '\\' if chars.peek() == Some(&'|') => {
                        cell.push('|');
                        chars.next();
                    }
                    '|' => cells.push(std::mem::take(&mut cell).trim().to_string()),
                    _ => cell.push(c),
                }
            }
            cells.push(cell.trim().to_string());
            current.push(cells);
        } else if !current.is_empty() {
            tables.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        tables.push(current);
    }
    tables
}

#[cfg(test)]
mod markdown_tests {
    use super::*;

    #[test]
    fn a_bar_in_a_cell_is_escaped_and_the_table_keeps_its_columns() {
        let mut r = Report::new("t");
        r.table(
            &["largest |uv|", "error"],
            &[vec!["1".into(), "|x|".into()]],
        );
        let tables = markdown_tables(r.as_str());
        assert_eq!(tables.len(), 1);
        assert!(tables[0].iter().all(|row| row.len() == 2), "{tables:?}");
        assert_eq!(tables[0][0][0], "largest |uv|");
        // Unescaped, the same header has four cells: the check fails a broken table.
        let broken = markdown_tables("| largest |uv| | error |\n|---|---|\n");
        assert_eq!(broken[0][0].len(), 4);
    }
}
