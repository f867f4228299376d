//! The source tree keeps its shape: no file over 800 lines outside the
//! tests, no files that import each other, a hardware crate that builds
//! without the simulator, Zenoh without the transports the project does
//! not offer, and docs/architecture.md's picture of the crates as they
//! are (`ROME_BLESS=1` writes it anew).

use crate::house::{self, MAX_LINES};
use crate::TestDir;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate sits in the workspace")
        .to_path_buf()
}

#[test]
fn no_source_file_outside_the_tests_reaches_800_lines() {
    let long = house::long_files(&root());
    assert!(
        long.is_empty(),
        "files of {MAX_LINES} lines or more: {long:#?}"
    );
}

#[test]
fn no_two_files_of_a_crate_import_each_other() {
    let mut found = Vec::new();
    for krate in house::crates(&root()) {
        found.extend(house::circles(&house::imports(&krate.join("src"))));
    }
    assert!(found.is_empty(), "files that import each other: {found:#?}");
}

#[test]
fn the_hardware_servers_build_without_the_simulator() {
    let crates = house::workspace(&root()).expect("the workspace's crates");
    let needs = house::needs(&crates, "rome-hardware");
    let allowed = ["rome-schema", "rome-serve", "rome-clock"];
    let extra: Vec<&String> = needs
        .iter()
        .filter(|n| !allowed.contains(&n.as_str()))
        .collect();
    assert!(
        extra.is_empty(),
        "rome-hardware needs {extra:?} beside {allowed:?}"
    );
    // And the simulated devices do reach both sides, through their adapter.
    let adapter = house::needs(&crates, "rome-sim-hardware");
    assert!(adapter.contains("rome-sim") && adapter.contains("rome-hardware"));
}

#[test]
fn no_crate_takes_zenohs_default_transports() {
    let meta = house::metadata(&root()).expect("cargo metadata");
    let found = house::zenoh_defaults(&meta);
    assert!(
        found.is_empty(),
        "taken with default features (write default-features = false): {found:#?}"
    );
    // A test-only dependency counts too: it is built with the workspace.
    let made_up = serde_json::json!({"packages": [{"name": "a", "dependencies": [
        {"name": "zenoh", "kind": null, "uses_default_features": false},
        {"name": "zenoh-ext", "kind": "dev", "uses_default_features": true},
    ]}]});
    assert_eq!(house::zenoh_defaults(&made_up), ["a → zenoh-ext (dev)"]);
}

/// The text between docs/architecture.md's markers.
const BEGIN: &str = "<!-- crates: begin (tests/src/house/tests.rs writes this) -->\n";
const END: &str = "<!-- crates: end -->";

#[test]
fn the_architecture_picture_shows_the_crates_as_they_are() {
    let crates = house::workspace(&root()).expect("the workspace's crates");
    let block = format!("```mermaid\n{}```\n", house::mermaid(&crates));
    let path = root().join("docs/architecture.md");
    let doc = std::fs::read_to_string(&path).expect("docs/architecture.md");
    let (Some(a), Some(b)) = (doc.find(BEGIN), doc.find(END)) else {
        panic!("docs/architecture.md has no {BEGIN:?} … {END:?} markers");
    };
    let now = &doc[a + BEGIN.len()..b];
    if std::env::var_os("ROME_BLESS").is_some() {
        let new = format!("{}{block}{}", &doc[..a + BEGIN.len()], &doc[b..]);
        std::fs::write(&path, new).expect("docs/architecture.md written");
        return;
    }
    assert_eq!(
        now, block,
        "docs/architecture.md's picture is not the crates' (ROME_BLESS=1 cargo test -p rome-tests --lib house writes it)"
    );
}

// The checks find what they look for: a made-up crate with a circle, a
// parent that merely declares its children, and a long file.

fn write(dir: &Path, rel: &str, text: &str) {
    let path = dir.join(rel);
    std::fs::create_dir_all(path.parent().expect("a parent")).expect("a folder");
    std::fs::write(path, text).expect("a file");
}

#[test]
fn a_circle_through_a_third_file_is_found_and_a_parent_declaring_its_children_is_not() {
    let dir = TestDir::new("house");
    let src = dir.path().join("src");
    write(
        &src,
        "lib.rs",
        "mod a;\nmod b;\nmod c;\npub use a::A;\nmod d;\n",
    );
    write(&src, "a.rs", "use crate::b::B;\npub struct A;\n");
    write(&src, "b.rs", "use super::c::{self, C};\npub struct B;\n");
    // Only a comment and a string name `a`: no import.
    write(
        &src,
        "c.rs",
        "// crate::a::A\nconst S: &str = \"crate::a\";\npub struct C(crate::a::A);\n",
    );
    write(&src, "d.rs", "mod e;\npub use e::E;\n");
    write(&src, "d/e.rs", "use super::super::b::B;\npub struct E;\n");
    let circles = house::circles(&house::imports(&src));
    assert_eq!(
        circles,
        vec![vec![src.join("a.rs"), src.join("b.rs"), src.join("c.rs")]],
        "{:#?}",
        house::imports(&src)
    );
    // Without the last arrow, no circle.
    write(&src, "c.rs", "// crate::a::A\npub struct C;\n");
    assert!(house::circles(&house::imports(&src)).is_empty());
}

#[test]
fn a_long_file_is_found_and_its_tests_are_not() {
    let dir = TestDir::new("house");
    write(dir.path(), "Cargo.toml", "[package]\nname = \"x\"\n");
    let long = "fn f() {}\n".repeat(MAX_LINES);
    write(dir.path(), "src/lib.rs", &long);
    write(dir.path(), "src/lib/tests.rs", &long);
    write(dir.path(), "tests/t.rs", &long);
    let found = house::long_files(dir.path());
    assert_eq!(found, vec![(dir.path().join("src/lib.rs"), MAX_LINES)]);
}
