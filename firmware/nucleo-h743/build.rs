//! Links with cortex-m-rt's `link.x` and this board's map (the STM32H743ZI
//! one in `memory.x`): see `../link_map.rs`.

include!("../link_map.rs");

fn main() {
    link_board_map();
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    // defmt's log-string table (defmt.x comes from defmt's own build
    // script, on the search path); this board's binaries only, so the QEMU
    // board, built in its own cargo invocation, never sees it.
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
