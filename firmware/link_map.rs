// Shared by both boards' build scripts (`include!`d): put this board's
// memory map where cortex-m-rt's `link.x` finds it, independent of the
// linker's cwd.
//
// `link.x` does `INCLUDE memory.x`; the one `memory.x` the linker can find
// is the workspace root's, which only includes `lm-board-memory.x`: this
// board's map, copied into `OUT_DIR` here. The root file is checked to be
// that include and nothing else, so it cannot shadow a board's map.

use std::path::{Path, PathBuf};

/// The one line the root `memory.x` may hold besides comments.
const ROOT_INCLUDE: &str = "INCLUDE lm-board-memory.x";

/// Copies the board's `memory.x` into `OUT_DIR` as `lm-board-memory.x`,
/// checks the root `memory.x`, and puts both on the linker's search path.
fn link_board_map() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let board_map = manifest.join("memory.x");
    std::fs::copy(&board_map, out.join("lm-board-memory.x")).expect("copy memory.x to OUT_DIR");
    let root = manifest.join("../..");
    check_root_map(&root.join("memory.x"));
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-search={}", root.display());
    println!("cargo:rerun-if-changed={}", board_map.display());
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../link_map.rs");
}

/// Panics unless `path` is only comments and [`ROOT_INCLUDE`].
fn check_root_map(path: &Path) {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e} (the root memory.x is required)", path.display()));
    let mut rest = text.as_str();
    let mut code = String::new();
    while let Some(start) = rest.find("/*") {
        code.push_str(&rest[..start]);
        let end = rest[start..]
            .find("*/")
            .expect("unterminated comment in root memory.x");
        rest = &rest[start + end + 2..];
    }
    code.push_str(rest);
    let words: Vec<&str> = code.split_whitespace().collect();
    assert_eq!(
        words.join(" "),
        ROOT_INCLUDE,
        "{} must hold only `{ROOT_INCLUDE}`: a map there would shadow the board's",
        path.display()
    );
}
