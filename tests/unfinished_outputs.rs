//! `io::remove_unfinished_outputs` deletes the temporaries of outputs not
//! yet committed (what the command line calls on SIGINT/SIGTERM/SIGHUP and
//! on a panic) and touches nothing else. In a test binary of its own: the
//! call is process-wide, and would pull the temporaries from under any
//! other test writing at the same time.

use std::io::Write;

use strandfit::io::{remove_unfinished_outputs, AtomicFile};

fn names(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    v.sort();
    v
}

#[test]
fn unfinished_outputs_are_removed_and_committed_ones_kept() {
    let dir = tempfile::tempdir().unwrap();
    let mut done = AtomicFile::create(&dir.path().join("done.txt")).unwrap();
    done.write_all(b"done").unwrap();
    done.commit().unwrap();
    std::fs::write(dir.path().join("old.txt"), "old").unwrap();
    let mut half = AtomicFile::create(&dir.path().join("old.txt")).unwrap();
    half.write_all(b"half").unwrap();
    half.flush().unwrap();
    let during = names(dir.path());
    assert_eq!(during.len(), 3, "{during:?}");
    assert!(during
        .iter()
        .any(|n| n.starts_with(".strandfit-") && n.ends_with(".tmp")));
    assert_eq!(remove_unfinished_outputs(), 1);
    assert_eq!(names(dir.path()), ["done.txt", "old.txt"]);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("old.txt")).unwrap(),
        "old"
    );
    // The writer itself now fails to commit, with an error, not a panic.
    assert!(half.commit().is_err());
    assert_eq!(remove_unfinished_outputs(), 0);
    assert_eq!(names(dir.path()), ["done.txt", "old.txt"]);
}
