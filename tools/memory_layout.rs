// The memory layout of the thumbv7m-none-eabi builds, shared by the build scripts of the
// firmware (root `build.rs`) and `ekf-emu` through `include!`: `link/memory.x` (the STM32F103RE's
// map, code from 0x0800_0000), or with the `dfu` feature (issue #27) the same file with the code
// region moved behind ST's USB DFU bootloader, which takes 0x0800_0000..0x0800_3000 on the
// iNEMO V2 and starts the application at 0x0800_3000: FLASH from 0x0800_3000, 508 − 12 =
// 496 KiB, so that it still ends at 0x0807_F000 and the settings pages (absolute addresses,
// `board::SETTINGS_PAGE_A`/`_B`) stay where they are. That copy is written to `OUT_DIR`, which
// then takes the place of `link/` on the linker's search path; the default images link exactly
// as before.
//
// `memory.x` is in `link/`, not in the workspace root: lld, and flip-link before it, look for an
// `INCLUDE`d script in the current directory — the workspace root, where cargo runs rustc —
// before the search path, so a `memory.x` there would always win over the DFU one.

/// The default image's code region (`link/memory.x`) and the DFU image's.
const FLASH_DEFAULT: &str = "FLASH : ORIGIN = 0x08000000, LENGTH = 508K";
const FLASH_DFU: &str = "FLASH : ORIGIN = 0x08003000, LENGTH = 496K";

/// Puts the memory layout on the link line of this package's binaries: `link/` of the workspace
/// at `root`, or the DFU layout when `dfu`.
#[allow(dead_code)]
fn link_memory_layout(root: &std::path::Path, dfu: bool) {
    let link = root.join("link");
    println!("cargo:rerun-if-changed={}", link.join("memory.x").display());
    if !dfu {
        println!("cargo:rustc-link-search={}", link.display());
        return;
    }
    let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory = std::fs::read_to_string(link.join("memory.x")).expect("read link/memory.x");
    assert_eq!(
        memory.matches(FLASH_DEFAULT).count(),
        1,
        "link/memory.x: the FLASH region is no longer `{FLASH_DEFAULT}`: update tools/memory_layout.rs"
    );
    let memory = format!(
        "/* Written by the build script (tools/memory_layout.rs) for the `dfu` feature: \
         link/memory.x with the code behind ST's DFU bootloader. */\n{}",
        memory.replace(FLASH_DEFAULT, FLASH_DFU)
    );
    std::fs::write(out.join("memory.x"), memory).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    // lld puts the ELF and program headers into a loadable segment of their own when they fit
    // between the start of a "page" (64 KiB by default) and the first section: here at
    // 0x0800_0000, ST's bootloader, where a tool that loads an ELF by its program headers
    // (OpenOCD's `load_image`) would write them. With 4 KiB pages (0x0800_3000 is a multiple)
    // there is no room, and no such segment (`scripts/dfu-image` checks that nothing is loaded
    // below 0x0800_3000).
    println!("cargo:rustc-link-arg-bins=-zmax-page-size=4096");
}
