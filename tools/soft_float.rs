// Soft-float routines of the thumbv7m-none-eabi builds, shared by the build scripts of the
// firmware (root `build.rs`), `ekf-emu` and `cycle-bench` through `include!`, so that what is
// measured is what is flashed.
//
// The Cortex-M3 has no FPU: every `f32` operation is a library call. Rust's own
// `compiler-builtins` routines take about twice the cycles of libgcc's hand-written Thumb-2
// ones (`ieee754-sf.S`: fadd 120 → 58 cycles, fmul 89 → 42; docs/performance.md), and both
// round correctly, so results are bit-identical. When libgcc's Cortex-M3 soft-float multilib
// (`thumb/v7-m/nofp/libgcc.a`) is found, it is linked; `compiler_builtins`' intrinsics are weak,
// so libgcc's strong `__aeabi_f*`/`__aeabi_d*` win with no duplicate symbol.
//
// - Unset or `AHRS_SOFTFLOAT=libgcc`: libgcc, and the build fails when it cannot be found, so
//   that the image (and its cycle counts) is the same on every machine (issue #16: it used to
//   fall back silently). `AHRS_SOFTFLOAT=builtins`: compiler-builtins, on purpose (a different
//   image: about twice the soft-float cycles); `auto`: libgcc when found, else compiler-builtins
//   with a build warning (the old default, for a quick build on a machine without the
//   cross-compiler).
// - Where libgcc is looked for: `AHRS_LIBGCC` (path of a `libgcc.a`), else
//   `arm-none-eabi-gcc -mcpu=cortex-m3 -mthumb -mfloat-abi=soft -print-libgcc-file-name`
//   (`ARM_NONE_EABI_GCC` names another command). `scripts/setup.sh` installs Debian's
//   `gcc-arm-none-eabi` for it. libgcc is GPLv3 with the GCC Runtime Library Exception, which
//   permits linking it into non-GPL firmware; it is never copied into this repository.
// - The choice is passed to the crate as the compile-time variable `AHRS_SOFTFLOAT_USED`
//   (`libgcc` or `compiler-builtins`).
//
// `-l static:-bundle=gcc` from a build script lands on the link line with this crate's objects,
// before the rlibs and so before `compiler_builtins` (`-C link-arg=-lgcc` would land after it
// and lose silently); `-bundle` keeps the archive out of a library's rlib. memory.x places
// libgcc's code (`.text.softfloat`) right after the vector table.

/// Link the soft-float routines for a `thumbv7m-none-eabi` build; returns what was linked.
#[allow(dead_code)]
fn link_soft_float() -> &'static str {
    println!("cargo:rerun-if-env-changed=AHRS_SOFTFLOAT");
    println!("cargo:rerun-if-env-changed=AHRS_LIBGCC");
    println!("cargo:rerun-if-env-changed=ARM_NONE_EABI_GCC");
    let mode = std::env::var("AHRS_SOFTFLOAT").unwrap_or_default();
    let required = match mode.as_str() {
        "builtins" => return use_soft_float("compiler-builtins"),
        "" | "libgcc" => true,
        "auto" => false,
        other => panic!("AHRS_SOFTFLOAT={other}: expected `libgcc`, `builtins` or `auto`"),
    };
    match find_libgcc() {
        Ok(lib) => {
            println!("cargo:rerun-if-changed={}", lib.display());
            let dir = lib.parent().expect("libgcc.a has a directory");
            println!("cargo:rustc-link-search=native={}", dir.display());
            println!("cargo:rustc-link-lib=static:-bundle=gcc");
            use_soft_float("libgcc")
        }
        Err(why) if required => panic!(
            "soft-float: {why}. The firmware links libgcc's Cortex-M3 soft-float so that every \
             machine builds the same image: install it (Debian: apt install gcc-arm-none-eabi; \
             scripts/setup.sh does) or point AHRS_LIBGCC at a thumb/v7-m/nofp/libgcc.a. \
             AHRS_SOFTFLOAT=builtins builds a different, slower image on purpose."
        ),
        Err(why) => {
            println!(
                "cargo:warning=soft-float: {why}; using compiler-builtins' routines (about \
                 twice the cycles: docs/performance.md). Debian: apt install gcc-arm-none-eabi"
            );
            use_soft_float("compiler-builtins")
        }
    }
}

#[allow(dead_code)]
fn use_soft_float(which: &'static str) -> &'static str {
    println!("cargo:rustc-env=AHRS_SOFTFLOAT_USED={which}");
    which
}

/// The Cortex-M3 (v7-M, no FPU) `libgcc.a`.
#[allow(dead_code)]
fn find_libgcc() -> Result<std::path::PathBuf, String> {
    if let Ok(p) = std::env::var("AHRS_LIBGCC") {
        let p = std::path::PathBuf::from(p);
        return if p.is_file() { Ok(p) } else { Err(format!("AHRS_LIBGCC={}: no such file", p.display())) };
    }
    let gcc = std::env::var("ARM_NONE_EABI_GCC").unwrap_or_else(|_| "arm-none-eabi-gcc".into());
    let out = std::process::Command::new(&gcc)
        .args(["-mcpu=cortex-m3", "-mthumb", "-mfloat-abi=soft", "-print-libgcc-file-name"])
        .output()
        .map_err(|e| format!("cannot run {gcc} ({e})"))?;
    let lib = std::path::PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    if out.status.success() && lib.is_file() {
        Ok(lib)
    } else {
        Err(format!("{gcc} -print-libgcc-file-name gave no libgcc.a ({})", lib.display()))
    }
}
