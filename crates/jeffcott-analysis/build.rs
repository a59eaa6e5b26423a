//! Records the git commit this crate is built from as `JEFFCOTT_COMMIT`, for run.json
//! and `jeffcott --version`: the package version alone cannot tell two builds apart.
//! Set `JEFFCOTT_COMMIT` to name it where the source has no git history (a tarball);
//! otherwise it is `git rev-parse --short=12 HEAD`, or `unknown` without git.

use std::process::Command;

/// `git ARGS` in the crate's folder, its trimmed output if it succeeded.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_string())
}

fn main() {
    println!("cargo:rerun-if-env-changed=JEFFCOTT_COMMIT");
    let commit = std::env::var("JEFFCOTT_COMMIT")
        .ok()
        .filter(|c| !c.is_empty())
        .or_else(|| git(&["rev-parse", "--short=12", "HEAD"]))
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=JEFFCOTT_COMMIT={commit}");
    // Built again when HEAD moves: the HEAD file, the branch it names and the packed
    // refs (where git keeps a branch after `git gc`). Only files that exist are named:
    // Cargo runs a build script again at every build while a named file is missing.
    let branch = git(&["symbolic-ref", "-q", "HEAD"]);
    let names = ["HEAD", "packed-refs"].into_iter().chain(branch.as_deref());
    println!("cargo:rerun-if-changed=build.rs");
    for name in names {
        if let Some(path) = git(&["rev-parse", "--git-path", name])
            && std::path::Path::new(&path).exists()
        {
            println!("cargo:rerun-if-changed={path}");
        }
    }
}
