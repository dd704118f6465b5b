//! Builds the examples `petrel demo` flies into the binary: the project
//! files of `examples/uav-flight-test` and `examples/ugv-bottleneck` (their
//! `.toml`, `.md` and `.py` files at the top of the folder — not DEC's
//! sources nor the scripts).

use std::fmt::Write as _;
use std::path::Path;

/// (the constant's name, the example's folder under examples/)
const EXAMPLES: &[(&str, &str)] = &[
    ("FLIGHT_TEST", "uav-flight-test"),
    ("UGV_BOTTLENECK", "ugv-bottleneck"),
];

fn main() {
    let mut out = String::new();
    for (constant, folder) in EXAMPLES {
        embed(&mut out, constant, folder);
    }
    let dest = Path::new(&std::env::var("OUT_DIR").unwrap_or_default()).join("examples.rs");
    if let Err(e) = std::fs::write(&dest, out) {
        panic!("cannot write {}: {e}", dest.display());
    }
}

fn embed(out: &mut String, constant: &str, folder: &str) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(folder);
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files: Vec<String> = std::fs::read_dir(&root)
        .map(|dir| {
            dir.filter_map(Result::ok)
                .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
                .filter_map(|e| e.file_name().into_string().ok())
                .filter(|name| [".toml", ".md", ".py"].iter().any(|x| name.ends_with(x)))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    let _ = writeln!(
        out,
        "/// The files of examples/{folder}, by name.\npub const {constant}: &[(&str, &str)] = &["
    );
    for name in &files {
        let path = root.join(name);
        println!("cargo:rerun-if-changed={}", path.display());
        let _ = writeln!(
            out,
            "    ({name:?}, include_str!({:?})),",
            path.display().to_string()
        );
    }
    out.push_str("];\n");
}
