//! With the `denoise` feature, lets the binary find Open Image Denoise
//! where it was linked (`OIDN_DIR/lib`, an rpath), so that it runs
//! without LD_LIBRARY_PATH.

fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_none() {
        return;
    }
    if let Some(dir) = std::env::var_os("OIDN_DIR").filter(|d| !d.is_empty()) {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
