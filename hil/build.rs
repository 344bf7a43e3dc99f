//! Link set-up of the on-target tests: cortex-m-rt's `link.x` with the firmware's `memory.x`
//! (the workspace's `link/`), embedded-test's `embedded-test.x`, defmt's `defmt.x`, and libgcc's
//! soft-float as the firmware links it (`tools/soft_float.rs`).
use std::{env, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("manifest dir"));
        let link = manifest.parent().expect("workspace root").join("link");
        println!("cargo:rustc-link-search={}", link.display());
        println!("cargo:rerun-if-changed={}", link.join("memory.x").display());
        println!("cargo:rustc-link-arg=-Tlink.x");
        println!("cargo:rustc-link-arg=-Tembedded-test.x");
        println!("cargo:rustc-link-arg=-Tdefmt.x");
        link_soft_float();
    }
}

include!("../tools/soft_float.rs");
