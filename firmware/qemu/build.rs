//! Links with cortex-m-rt's `link.x` and this board's map (the mps2-an500
//! one in `memory.x`): see `../link_map.rs`.

include!("../link_map.rs");

fn main() {
    link_board_map();
    if std::env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
    }
}
