//! What each kind of target gets: regular files replaced atomically, symlinks followed,
//! devices and pipes streamed into, folders refused.

use madenet_files::{write_atomic, AtomicFile};
use madenet_testkit::entries as names;
use std::io::Write;
use std::path::Path;

#[test]
fn a_regular_file_is_replaced_and_no_temporary_file_is_left() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out.csv");
    write_atomic(&p, b"old").unwrap();
    write_atomic(&p, b"new").unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"new");
    assert_eq!(names(dir.path()), ["out.csv"]);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&p).unwrap().permissions().mode();
        assert_ne!(
            mode & 0o044,
            0,
            "readable by others like File::create's files: {mode:o}"
        );
    }
}

#[test]
fn an_uncommitted_file_leaves_the_target_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out.txt");
    write_atomic(&p, b"kept").unwrap();
    {
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"half").unwrap();
    }
    assert_eq!(std::fs::read(&p).unwrap(), b"kept");
    assert_eq!(names(dir.path()), ["out.txt"]);
}

#[cfg(unix)]
#[test]
fn a_symlink_stays_a_link_and_its_target_is_replaced() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("results")).unwrap();
    let target = dir.path().join("results/run1.csv");
    std::fs::write(&target, b"old").unwrap();
    let link = dir.path().join("latest.csv");
    std::os::unix::fs::symlink("results/run1.csv", &link).unwrap();
    // and a link to that link
    let link2 = dir.path().join("latest2.csv");
    std::os::unix::fs::symlink(&link, &link2).unwrap();
    write_atomic(&link2, b"new").unwrap();
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::symlink_metadata(&link2)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), b"new");
    assert_eq!(names(dir.path().join("results")), ["run1.csv"]);
    // A dangling link creates its target.
    let dangling = dir.path().join("next.csv");
    std::os::unix::fs::symlink("results/run2.csv", &dangling).unwrap();
    write_atomic(&dangling, b"via path").unwrap();
    assert!(std::fs::symlink_metadata(&dangling)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(
        std::fs::read(dir.path().join("results/run2.csv")).unwrap(),
        b"via path"
    );
}

#[cfg(unix)]
#[test]
fn a_device_or_pipe_is_written_into_not_replaced() {
    // /dev/null stays a character device.
    write_atomic(Path::new("/dev/null"), b"discarded").unwrap();
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
    // A FIFO gets the bytes, and stays a FIFO.
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    let ok = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(ok.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(&fifo).unwrap())
    };
    write_atomic(&fifo, b"streamed").unwrap();
    assert_eq!(reader.join().unwrap(), b"streamed");
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    assert_eq!(names(dir.path()), ["pipe"]);
}

#[test]
fn a_folder_is_refused_and_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("out");
    std::fs::create_dir(&sub).unwrap();
    let e = write_atomic(&sub, b"x").unwrap_err();
    assert!(e.to_string().contains("folder"), "{e}");
    assert!(sub.is_dir());
    assert_eq!(names(dir.path()), ["out"]);
}

#[test]
fn a_folder_is_one_runs_and_its_stale_temporary_files_go() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(".madenet-AbC123"), b"torn").unwrap();
    std::fs::write(dir.path().join("trials.csv"), b"kept").unwrap();
    let lock = madenet_files::lock_folder(dir.path()).unwrap();
    assert!(!dir.path().join(".madenet-AbC123").exists());
    assert_eq!(
        std::fs::read(dir.path().join("trials.csv")).unwrap(),
        b"kept"
    );
    let second = madenet_files::lock_folder(dir.path()).unwrap_err();
    assert_eq!(second.kind(), std::io::ErrorKind::WouldBlock);
    assert!(
        second.to_string().contains("another madenet run"),
        "{second}"
    );
    drop(lock);
    // Released with the file: a child another test spawns at this moment holds a copy of the
    // descriptor until its `exec` closes it, so allow it a moment.
    let t0 = std::time::Instant::now();
    while let Err(e) = madenet_files::lock_folder(dir.path()) {
        assert!(t0.elapsed().as_secs() < 5, "{e}");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

#[test]
fn a_write_in_progress_survives_the_cleanup_of_interrupted_ones() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(".madenet-stale1"), b"torn").unwrap();
    let mut writing = madenet_files::AtomicFile::create(&dir.path().join("out.csv")).unwrap();
    writing.write_all(b"a,b\n").unwrap();
    let _lock = madenet_files::lock_folder(dir.path()).unwrap();
    assert!(
        !dir.path().join(".madenet-stale1").exists(),
        "stale one removed"
    );
    let temps = std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            let name = e.as_ref().unwrap().file_name();
            let name = name.to_string_lossy();
            name.starts_with(".madenet-") && name != ".madenet.lock"
        })
        .count();
    assert_eq!(temps, 1, "the write in progress kept its temporary file");
    writing.write_all(b"1,2\n").unwrap();
    writing.commit().unwrap();
    assert_eq!(
        std::fs::read(dir.path().join("out.csv")).unwrap(),
        b"a,b\n1,2\n"
    );
}

/// An output that is an input (directly, through a symbolic link, or by another spelling of its
/// path) or another output is refused naming both flags; distinct paths pass.
#[test]
fn an_output_may_not_be_an_input_or_another_output() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("m.txt");
    std::fs::write(&map, "..\n").unwrap();
    let link = dir.path().join("link.txt");
    #[cfg(unix)]
    std::os::unix::fs::symlink(&map, &link).unwrap();
    let dotted = dir.path().join(".").join("m.txt");
    let input = [("--maps", map.as_path())];
    for out in [&map, &dotted] {
        let e = madenet_files::check_outputs(&[("--out", out)], &input).unwrap_err();
        assert!(e.contains("--out") && e.contains("--maps"), "{e}");
    }
    #[cfg(unix)]
    assert!(madenet_files::check_outputs(&[("--out", &link)], &input).is_err());
    let (a, b) = (dir.path().join("a.png"), dir.path().join("new/../a.png"));
    assert!(madenet_files::check_outputs(&[("--out", &a)], &input).is_ok());
    let e = madenet_files::check_outputs(&[("--render", &a), ("--snapshot", &a)], &[]).unwrap_err();
    assert!(e.contains("--snapshot") && e.contains("--render"), "{e}");
    // A path through a folder that does not exist is compared as given.
    assert!(madenet_files::check_outputs(&[("--out", &b)], &input).is_ok());
}
