//! Builds every plugin of the tests as a shared library in OUT_DIR with the system C compiler
//! (through the `cc` crate: it finds `cc`, and the flags of the target), from
//! `plugins/example/*.c` (what the README shows) and `c/*.c` (broken on purpose).

use std::path::{Path, PathBuf};
use std::process::Command;

const PLUGINS: &[(&str, &str)] = &[
    ("c_ocsi", "../../plugins/example/ocsi.c"),
    ("c_arvo", "../../plugins/example/arvo.c"),
    ("always_overlap", "c/always_overlap.c"),
    ("segfault", "c/segfault.c"),
    ("f64_only", "c/f64_only.c"),
];

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let include = Path::new("../../include");
    println!("cargo:rerun-if-changed={}", include.display());
    let compiler = cc::Build::new().opt_level(2).get_compiler();
    for (name, source) in PLUGINS {
        println!("cargo:rerun-if-changed={source}");
        let library = out.join(format!("lib{name}.so"));
        let mut command: Command = compiler.to_command();
        command
            // The flags the examples' sources give (see plugins/example/ocsi.c).
            .args(["-ffinite-math-only", "-fno-signed-zeros"])
            .args(["-shared", "-fPIC", "-std=c99", "-Wall", "-Werror", "-I"])
            .arg(include)
            .arg("-o")
            .arg(&library)
            .arg(source);
        let status = command
            .status()
            .unwrap_or_else(|e| panic!("cannot run the C compiler for {source}: {e}"));
        assert!(status.success(), "the C compiler failed on {source}");
    }
}
