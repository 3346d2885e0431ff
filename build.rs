//! Puts `memory.x` on the linker search path for the Cortex-M examples. Harmless on the host:
//! only the thumbv7em target's rustflags pass `-Tlink.x`, which reads it.
use std::{env, fs, path::PathBuf};

fn main() {
    if let Some(out) = env::var_os("OUT_DIR").map(PathBuf::from) {
        if fs::copy("memory.x", out.join("memory.x")).is_ok() {
            println!("cargo:rustc-link-search={}", out.display());
        }
    }
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}
