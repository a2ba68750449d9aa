//! The rules of [`super`]: whole or absent, destinations looked at first,
//! inputs never overwritten.

use std::path::Path;

use super::*;

fn scratch(name: &str) -> super::Scratch {
    super::scratch(&format!("files-{name}"))
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn an_uncommitted_output_leaves_nothing_and_keeps_the_old_file() {
    let d = scratch("uncommitted");
    let p = d.join("out.bin");
    std::fs::write(&p, b"old").unwrap();
    let mut o = Output::create(&p).unwrap();
    o.write_bytes(b"new, half").unwrap();
    drop(o);
    assert_eq!(names(&d), ["out.bin"]);
    assert_eq!(std::fs::read(&p).unwrap(), b"old");
    write_whole(&p, b"new").unwrap();
    assert_eq!(names(&d), ["out.bin"]);
    assert_eq!(std::fs::read(&p).unwrap(), b"new");
}

#[test]
fn a_log_not_started_leaves_the_old_file_and_makes_no_new_one() {
    let d = scratch("pending");
    let old = d.join("old.jsonl");
    std::fs::write(&old, b"{\"event\":\"closed\"}\n").unwrap();
    drop(AppendLog::prepare(&old).unwrap());
    assert_eq!(std::fs::read(&old).unwrap(), b"{\"event\":\"closed\"}\n");
    drop(AppendLog::prepare(&d.join("new.jsonl")).unwrap());
    assert_eq!(names(&d), ["old.jsonl"]);
    // Started, it is a log afresh; an existing file emptied only now.
    let mut log = AppendLog::prepare(&old).unwrap().start().unwrap();
    log.line("a").unwrap();
    drop(log);
    assert_eq!(std::fs::read(&old).unwrap(), b"a\n");
    let mut log = AppendLog::prepare(&d.join("new.jsonl"))
        .unwrap()
        .start()
        .unwrap();
    log.line("b").unwrap();
    drop(log);
    assert_eq!(std::fs::read(d.join("new.jsonl")).unwrap(), b"b\n");
    // A path it cannot write fails at once.
    assert!(AppendLog::prepare(&d.join("no/such.jsonl")).is_err());
    assert!(AppendLog::prepare(&d).is_err());
}

#[test]
fn an_output_folder_made_and_left_empty_is_removed() {
    let d = scratch("made");
    // Refused or stopped before writing: every folder made goes again.
    drop(output_dir("--out", &d.join("a/b/c")).unwrap());
    assert!(names(&d).is_empty(), "{:?}", names(&d));
    // One written into stays, with the folders above it.
    let made = output_dir("--out", &d.join("a/b")).unwrap();
    std::fs::write(d.join("a/b/x.json"), b"{}").unwrap();
    drop(made);
    assert!(d.join("a/b/x.json").exists());
    // A folder that was there is never removed, empty or not.
    std::fs::create_dir(d.join("was")).unwrap();
    drop(output_dir("--out", &d.join("was")).unwrap());
    drop(output_dir("--out", &d.join("was/new")).unwrap());
    assert_eq!(names(&d), ["a", "was"]);
    assert!(names(&d.join("was")).is_empty());
}

#[test]
fn a_header_rewritten_at_the_end_lands_at_its_offset() {
    let d = scratch("write_at");
    let p = d.join("h.bin");
    let mut o = Output::create(&p).unwrap();
    o.write_bytes(b"....tail").unwrap();
    o.write_at(0, b"HEAD").unwrap();
    o.write_bytes(b"+more").unwrap();
    o.commit().unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"HEADtail+more");
}

#[test]
fn a_wrapped_io_error_is_said_in_words() {
    #[derive(Debug, thiserror::Error)]
    #[error("encoder: {0}")]
    struct Wrapped(#[source] std::io::Error);
    let w = Wrapped(std::io::Error::from_raw_os_error(libc::ENOSPC));
    assert_eq!(reason_of(&w), "no space left on device");
    #[derive(Debug, thiserror::Error)]
    #[error("{0}")]
    struct Text(&'static str);
    let text =
        Text("ImageError(IoError(Custom { error: \"No space left on device (os error 28)\" }))");
    assert_eq!(reason_of(&text), "no space left on device");
    let plain = std::fmt::Error;
    assert_eq!(reason_of(&plain), plain.to_string());
}

#[test]
fn odd_inputs_are_refused_by_kind_without_blocking() {
    let d = scratch("inputs");
    let fifo = d.join("fifo");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
    let e = open_input("--scene file", &fifo).unwrap_err().to_string();
    assert!(e.contains("FIFO") && e.contains("fifo"), "{e}");
    let e = open_input("--scene file", &d).unwrap_err().to_string();
    assert!(e.contains("directory"), "{e}");
    let e = open_input("--scene file", Path::new("/dev/null"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("device node"), "{e}");
    let e = open_input("--scene file", &d.join("missing"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no such file"), "{e}");
}

#[test]
fn an_output_onto_an_input_is_refused_also_through_a_link() {
    let d = scratch("same");
    let input = d.join("scene.toml");
    std::fs::write(&input, b"x = 1\n").unwrap();
    std::os::unix::fs::symlink(&input, d.join("link.toml")).unwrap();
    std::fs::hard_link(&input, d.join("hard.toml")).unwrap();
    open_input("--scene file", &input).unwrap();
    for p in ["scene.toml", "link.toml", "hard.toml"] {
        let e = Output::create(&d.join(p)).unwrap_err();
        assert!(e.is::<InputError>(), "{e}");
    }
    assert_eq!(std::fs::read(&input).unwrap(), b"x = 1\n");
    Output::create(&d.join("other.toml")).unwrap();
    let a = d.join("a.npy");
    let e = distinct_outputs(&[("--record", &a), ("--plot", &d.join(".").join("a.npy"))]);
    assert!(e.unwrap_err().to_string().contains("are the same path"));
}

#[test]
fn a_folder_given_a_deleted_inputs_identity_is_not_that_input() {
    // The file system reuses a deleted file's identity (device, inode):
    // a fresh output folder can get the one an input read and deleted
    // earlier in the process had. Inputs are regular files, so only a
    // regular file can be one, and only while the input's name still
    // names it (a test's scratch folder removed, its inodes reused).
    let d = scratch("reused");
    let out = d.join("out");
    std::fs::create_dir(&out).unwrap();
    let file = d.join("still.toml");
    std::fs::write(&file, b"x = 1\n").unwrap();
    let fresh = d.join("fresh.toml");
    std::fs::write(&fresh, b"x = 2\n").unwrap();
    {
        let mut inputs = INPUTS.lock().unwrap();
        for (p, named) in [
            (&out, d.join("gone.toml")),
            (&file, file.clone()),
            (&fresh, d.join("gone.toml")),
        ] {
            inputs.push((id(&std::fs::metadata(p).unwrap()), named));
        }
    }
    let _made = output_dir("--out", &out).unwrap();
    let e = not_an_input("--out", &file).unwrap_err();
    assert!(e.to_string().contains("still.toml"), "{e}");
    not_an_input("--out", &fresh).unwrap();
}

fn mode(p: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::metadata(p).unwrap().permissions().mode() & 0o7777
}

#[test]
fn a_symlink_is_followed_and_its_target_replaced() {
    let d = scratch("symlink");
    let real = d.join("real.toml");
    std::fs::write(&real, b"old").unwrap();
    std::os::unix::fs::symlink("real.toml", d.join("link.toml")).unwrap();
    // A chain of links, one of them absolute.
    std::os::unix::fs::symlink(d.join("link.toml"), d.join("chain.toml")).unwrap();
    write_whole(&d.join("chain.toml"), b"new").unwrap();
    assert_eq!(std::fs::read(&real).unwrap(), b"new");
    for l in ["link.toml", "chain.toml"] {
        let m = std::fs::symlink_metadata(d.join(l)).unwrap();
        assert!(m.file_type().is_symlink(), "{l} is still a link");
    }
    replace_input(&d.join("link.toml"), b"newer").unwrap();
    assert_eq!(std::fs::read(&real).unwrap(), b"newer");
    // A dangling link: its target is created, the link kept.
    std::os::unix::fs::symlink("made.npy", d.join("dangling.npy")).unwrap();
    write_whole(&d.join("dangling.npy"), b"x").unwrap();
    assert_eq!(std::fs::read(d.join("made.npy")).unwrap(), b"x");
    assert!(
        std::fs::symlink_metadata(d.join("dangling.npy"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    // A loop is an error, not a hang.
    std::os::unix::fs::symlink("loop_b", d.join("loop_a")).unwrap();
    std::os::unix::fs::symlink("loop_a", d.join("loop_b")).unwrap();
    let e = write_whole(&d.join("loop_a"), b"x")
        .unwrap_err()
        .to_string();
    assert!(e.contains("loop_a") && e.contains("symbolic links"), "{e}");
    assert_eq!(
        names(&d),
        [
            "chain.toml",
            "dangling.npy",
            "link.toml",
            "loop_a",
            "loop_b",
            "made.npy",
            "real.toml"
        ]
    );
}

#[test]
fn a_replaced_file_keeps_its_mode_and_owner() {
    use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
    let d = scratch("mode");
    let p = d.join("secret.json");
    std::fs::write(&p, b"old").unwrap();
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
    let mut o = Output::create(&p).unwrap();
    o.write_bytes(b"new").unwrap();
    // Private while it is written.
    let tmp = names(&d).into_iter().find(|n| n.contains(".tmp")).unwrap();
    assert_eq!(mode(&d.join(tmp)), 0o600);
    o.commit().unwrap();
    assert_eq!(mode(&p), 0o600);
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
    write_whole(&p, b"newer").unwrap();
    assert_eq!(mode(&p), 0o640);
    // SAFETY: geteuid has no preconditions and cannot fail.
    if unsafe { libc::geteuid() } == 0 {
        std::os::unix::fs::chown(&p, Some(4321), Some(4322)).unwrap();
        write_whole(&p, b"root keeps the owner").unwrap();
        let m = std::fs::metadata(&p).unwrap();
        assert_eq!((m.uid(), m.gid()), (4321, 4322));
    } else {
        println!("not root: the owner part of this test needs root");
    }
}

#[test]
fn a_hard_link_is_broken_only_under_the_name_written() {
    let d = scratch("hard");
    let a = d.join("a.npy");
    std::fs::write(&a, b"old").unwrap();
    std::fs::hard_link(&a, d.join("b.npy")).unwrap();
    write_whole(&a, b"new").unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), b"new");
    assert_eq!(std::fs::read(d.join("b.npy")).unwrap(), b"old");
}

#[test]
fn devices_and_pipes_are_written_in_place_or_refused() {
    use std::os::unix::fs::FileTypeExt as _;
    let d = scratch("devices");
    // A character device is written in place: it stays a device.
    write_whole(Path::new("/dev/null"), b"discarded").unwrap();
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    let e = write_whole(Path::new("/dev/full"), &[0; 10_000])
        .unwrap_err()
        .to_string();
    assert_eq!(e, "cannot write /dev/full: no space left on device");
    // A FIFO with no reader fails at once instead of blocking.
    let fifo = d.join("fifo");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
    let e = Output::create(&fifo).unwrap_err();
    assert!(e.to_string().contains("no reader"), "{e}");
    assert!(!e.is::<InputError>());
    let e = AppendLog::create(&fifo).unwrap_err().to_string();
    assert!(e.contains("no reader"), "{e}");
    // With a reader, it gets the bytes.
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let mut log = loop {
        match AppendLog::create(&fifo) {
            Ok(l) => break l,
            Err(_) => std::thread::sleep(std::time::Duration::from_millis(5)),
        }
    };
    log.line("event 1").unwrap();
    log.sync().unwrap();
    drop(log);
    assert_eq!(reader.join().unwrap(), b"event 1\n");
    // A log to resume must be a regular file.
    let e = AppendLog::open(&fifo).unwrap_err();
    assert!(e.is::<InputError>(), "{e}");
    // A socket is never written.
    let sock = d.join("sock");
    let _l = std::os::unix::net::UnixListener::bind(&sock).unwrap();
    let e = write_whole(&sock, b"x").unwrap_err();
    assert!(
        e.is::<InputError>() && e.to_string().contains("socket"),
        "{e}"
    );
    assert!(std::fs::metadata(&sock).unwrap().file_type().is_socket());
    // A directory fails, naming it.
    let e = write_whole(&d, b"x").unwrap_err().to_string();
    assert!(e.ends_with("it is a directory"), "{e}");
}

#[test]
fn a_write_error_says_its_reason_once() {
    let e: anyhow::Error = write_whole(Path::new("/nonexistent-dir/x.npy"), b"x").unwrap_err();
    assert_eq!(
        crate::error::one_line(&e),
        "cannot write /nonexistent-dir/x.npy: its folder /nonexistent-dir does not exist"
    );
}

#[test]
fn a_killed_writers_temporary_file_goes_at_the_next_write_to_that_name() {
    let d = scratch("stale");
    // A process that has ended: its pid names no process now (reuse within
    // this test is not a concern: pids are handed out in order).
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let stale = format!(".rec.npy.lmhost-{dead}.tmp.npy");
    // pid 1 is alive: another writer's file is left alone, as are names
    // that only look alike and another destination's temporary file.
    let alive = ".rec.npy.lmhost-1.tmp.npy".to_owned();
    let other = format!(".other.npy.lmhost-{dead}.tmp.npy");
    let odd = format!(".rec.npy.lmhost-{dead}x.tmp.npy");
    for n in [&stale, &alive, &other, &odd] {
        std::fs::write(d.join(n), b"half a recording").unwrap();
    }
    write_whole(&d.join("rec.npy"), b"whole").unwrap();
    let mut want = vec![alive, other, odd, "rec.npy".to_owned()];
    want.sort();
    assert_eq!(names(&d), want);
}

#[test]
fn a_name_too_long_for_the_file_system_is_shown_cut_around_its_length() {
    // A name with spaces (from a file's value: a protocol's `library`),
    // past the 255 bytes a name may have: no cut of long words catches it.
    let d = scratch("too-long");
    let long = d.join("a b ".repeat(300));
    let e = super::read_input("stimulus library", &long, 1 << 20)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("cannot read stimulus library /"), "{e}");
    let n = long.display().to_string().chars().count();
    assert!(
        e.contains(&format!("…({n} characters)…")) && e.len() < 200,
        "{e}"
    );
    // A missing file of an ordinary name is named whole.
    let e = super::read_input("scene file", &d.join("none.toml"), 1 << 20)
        .unwrap_err()
        .to_string();
    assert!(e.ends_with("none.toml: no such file or directory"), "{e}");
}

#[test]
fn a_scratch_folder_left_by_an_ended_process_is_swept() {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let tmp = std::env::temp_dir();
    // No process has this id (above Linux's largest, 2^22).
    let ended = tmp.join("lmhost-files-sweep-999999999");
    let other = tmp.join("lmhost-files-sweep-x1");
    for d in [&ended, &other] {
        std::fs::create_dir_all(d.join("inner")).unwrap();
    }
    let d = scratch("sweep");
    assert!(!ended.exists(), "{} left", ended.display());
    assert!(other.exists(), "not a process's folder: kept");
    assert!(d.exists());
    std::fs::remove_dir_all(&other).unwrap();
}
