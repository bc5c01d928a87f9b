//! `reparam demo` writes `report.md` whose every table renders: each row has the header's
//! number of cells once escaped bars are honoured (issue #38: headers such as `largest |uv|`
//! split their column), and every picture it links exists.

use std::process::Command;

use reparam::report::markdown_tables;

#[test]
fn the_demo_report_tables_parse_and_its_pictures_exist() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let status = Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args(["demo", "--out", out.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success());
    let text = std::fs::read_to_string(out.join("report.md")).unwrap();
    let tables = markdown_tables(&text);
    assert!(tables.len() >= 10, "{} tables", tables.len());
    for table in &tables {
        let columns = table[0].len();
        for row in table {
            assert_eq!(
                row.len(),
                columns,
                "a row of {columns}-column table {:?}: {row:?}",
                table[0]
            );
        }
    }
    for link in text.split("](").skip(1) {
        let target = &link[..link.find(')').unwrap()];
        if target.ends_with(".png") {
            assert!(out.join(target).exists(), "{target}");
        }
    }
}
