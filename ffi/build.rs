//! Gives the shared library a SONAME (`libkincal.so.0`, the ABI's major version) on Linux,
//! so programs record the ABI they were linked against rather than the bare file name.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libkincal.so.0");
    }
}
