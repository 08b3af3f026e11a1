//! The CLI's one rule for where results go: never over a file the run reads. A typo in
//! `--out` or `--json` must not destroy the detections, the ground truth or a frame; every
//! command that writes checks its outputs against the files it reads before any work, with
//! the same comparison (the same file under any name: relative, absolute, through a link).
//! Also the peak memory a command's summary line reports, which says whether it streamed.

use std::path::{Path, PathBuf};

/// Whether two paths name the same existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Where a path would be written: its folder resolved (links, `..`), its own name kept, so
/// two outputs that do not exist yet still compare. `None` when the folder does not exist.
fn target(p: &Path) -> Option<PathBuf> {
    let name = p.file_name()?;
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}

/// Refuses two outputs of one run that are the same file (the second write would replace the
/// first), naming both flags.
pub fn refuse_same_output(flag_a: &str, a: &Path, flag_b: &str, b: &Path) -> crate::CliResult {
    if same_file(a, b) || target(a).is_some_and(|t| Some(t) == target(b)) {
        return Err(format!(
            "{flag_a} {} and {flag_b} {} are the same file: give each output its own",
            a.display(),
            b.display()
        )
        .into());
    }
    Ok(())
}

/// Refuses `out` (given as `flag`) when it is one of `inputs`, naming both. An output that
/// does not exist yet cannot be an input, so a first run always passes.
pub fn refuse_overwrite<'a, I>(flag: &str, out: &Path, inputs: I) -> crate::CliResult
where
    I: IntoIterator<Item = &'a Path>,
{
    if !out.exists() {
        return Ok(());
    }
    for input in inputs {
        if same_file(out, input) {
            return Err(format!(
                "{flag} {} is an input of this run ({}): write the output somewhere else",
                out.display(),
                input.display()
            )
            .into());
        }
    }
    Ok(())
}

/// Refuses `out` (given as `flag`) when it is an existing file inside one of `folders`, a
/// dataset whose every file the run may read, naming both.
pub fn refuse_inside(flag: &str, out: &Path, folders: &[PathBuf]) -> crate::CliResult {
    let Ok(out) = out.canonicalize() else {
        return Ok(());
    };
    match folders
        .iter()
        .find(|d| d.canonicalize().is_ok_and(|d| out.starts_with(d)))
    {
        Some(d) => Err(format!(
            "{flag} {} lies in the dataset {} this run reads: write it somewhere else",
            out.display(),
            d.display()
        )
        .into()),
        None => Ok(()),
    }
}

/// The process's peak resident memory (Linux `VmHWM`), for a command's summary line: a long
/// video must not make it grow (`track`'s online output and `vot`'s frames stream).
pub fn peak_memory_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_under_another_name_is_refused() {
        let dir = std::env::temp_dir().join(format!("shapetrack-outputs-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let input = dir.join("det.txt");
        std::fs::write(&input, "1,-1,0,0,1,1,1\n").unwrap();
        let other = dir.join("sub/../det.txt");
        let e = refuse_overwrite("--out", &other, [input.as_path()]).unwrap_err();
        assert!(e.to_string().contains("is an input of this run"), "{e}");
        assert!(refuse_overwrite("--out", &dir.join("new.txt"), [input.as_path()]).is_ok());
        assert!(refuse_overwrite("--out", &dir.join("sub"), [input.as_path()]).is_ok());
        // Two outputs, neither written yet, named differently.
        let e = refuse_same_output(
            "--out",
            &dir.join("t.txt"),
            "--joins",
            &dir.join("sub/../t.txt"),
        );
        assert!(e.unwrap_err().to_string().contains("are the same file"));
        assert!(
            refuse_same_output("--out", &dir.join("t.txt"), "--joins", &dir.join("j.txt")).is_ok()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
