//! The control endpoint, bound before the device opens (a bad `--control`
//! costs no device time): a Unix socket of mode 0600 (only its owner may
//! drive the array), optionally `127.0.0.1:PORT`, whose clients must first
//! send the session's token (from a file of mode 0600 beside the socket),
//! or stdin/stdout. The socket and the token file are removed when the
//! endpoint is dropped.

use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};

use crate::error::InputError;

/// Where commands come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Control {
    /// Commands on stdin, replies and events on stdout (end of input: the
    /// running timed presentation finishes, then the session ends).
    Stdio,
    /// A Unix socket at `unix` (mode 0600), and `127.0.0.1:tcp` if given.
    Socket {
        /// The socket's path.
        unix: PathBuf,
        /// A local TCP port as well.
        tcp: Option<u16>,
        /// What gave the path, as messages name it: `--control`, or the
        /// default's environment variable ([`default_socket`]).
        named: String,
    },
}

impl Control {
    /// Refuses, before anything is made, an event log (`events`) at the
    /// control socket's path or its token file's (with TCP), or either at
    /// an input's: the log was made first, and the socket then said its
    /// path "exists and is not a socket".
    pub fn check_outputs(&self, events: Option<&Path>) -> Result<(), InputError> {
        let mut outs: Vec<(&str, PathBuf)> = Vec::new();
        if let Self::Socket { unix, tcp, named } = self {
            outs.push((named, unix.clone()));
            if tcp.is_some() {
                outs.push(("the TCP token file", token_path(unix)));
            }
        }
        if let Some(e) = events {
            outs.push(("--events", e.to_owned()));
        }
        crate::files::distinct_outputs(&outs)
    }
}

/// The control socket when `--control` is not given, and what gave it
/// (for messages): `$XDG_RUNTIME_DIR/lmhost.sock` (an absolute
/// `$XDG_RUNTIME_DIR`, as the XDG spec has it), else
/// `/tmp/lmhost-$USER.sock` when `$USER` is a file name (no `/`, not `.`
/// or `..`), else `/tmp/lmhost-UID.sock`: a value of the environment
/// never places the socket outside those folders.
pub fn default_socket() -> Result<(PathBuf, String), InputError> {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    if let Some(d) = var("XDG_RUNTIME_DIR") {
        let d = PathBuf::from(d);
        if !d.is_absolute() {
            return Err(InputError::new(format!(
                "$XDG_RUNTIME_DIR `{}` is not an absolute path, so it holds no default control socket: give --control PATH (or an absolute $XDG_RUNTIME_DIR)",
                d.display()
            )));
        }
        let named =
            "the default control socket ($XDG_RUNTIME_DIR/lmhost.sock; give --control PATH)";
        return Ok((d.join("lmhost.sock"), named.into()));
    }
    let user = var("USER").and_then(|u| u.into_string().ok());
    // SAFETY: getuid has no preconditions and cannot fail.
    let uid = unsafe { libc::getuid() };
    Ok(user_socket(user.as_deref(), uid))
}

/// `/tmp/lmhost-USER.sock` for a `user` that is a file name, else
/// `/tmp/lmhost-UID.sock`, and what gave it.
fn user_socket(user: Option<&str>, uid: u32) -> (PathBuf, String) {
    match user.filter(|u| !u.contains(['/', '\0']) && *u != "." && *u != "..") {
        Some(u) => (
            PathBuf::from(format!("/tmp/lmhost-{u}.sock")),
            "the default control socket (/tmp/lmhost-$USER.sock; give --control PATH)".into(),
        ),
        None => (
            PathBuf::from(format!("/tmp/lmhost-{uid}.sock")),
            "the default control socket (/tmp/lmhost-UID.sock; give --control PATH)".into(),
        ),
    }
}

/// Longest Unix socket path, bytes: `sockaddr_un`'s `sun_path` holds 108
/// with the terminating NUL.
pub const MAX_SOCKET_PATH_BYTES: usize = 107;

/// The TCP clients' token: where it is and what it is.
pub struct Token {
    /// The file holding it (mode 0600).
    pub path: PathBuf,
    value: String,
}

impl Token {
    /// Whether `given` is the token (compared in constant time).
    pub fn matches(&self, given: &str) -> bool {
        let (a, b) = (self.value.as_bytes(), given.as_bytes());
        a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
    }
}

impl Drop for Token {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// A bound Unix socket, removed when dropped.
struct UnixSocket {
    path: PathBuf,
}

impl Drop for UnixSocket {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// A bound control endpoint.
pub struct Endpoint {
    pub(super) unix: Option<std::os::unix::net::UnixListener>,
    pub(super) tcp: Option<(std::net::TcpListener, Token)>,
    pub(super) stdio: bool,
    _socket: Option<UnixSocket>,
}

impl Endpoint {
    /// Binds `control`; with TCP, writes the token file `SOCKET.token`.
    pub fn bind(control: &Control) -> anyhow::Result<Self> {
        match control {
            Control::Stdio => Ok(Self {
                unix: None,
                tcp: None,
                stdio: true,
                _socket: None,
            }),
            Control::Socket { unix, tcp, named } => {
                // The token file exists before the socket does: a client
                // that can connect can read it.
                free_unix(unix, named)?;
                let tcp = tcp
                    .map(|port| -> anyhow::Result<_> {
                        let l = std::net::TcpListener::bind(("127.0.0.1", port)).map_err(|e| {
                            anyhow::anyhow!("--tcp 127.0.0.1:{port}: {}", crate::files::reason(&e))
                        })?;
                        Ok((l, write_token(&token_path(unix))?))
                    })
                    .transpose()?;
                let (listener, socket) = bind_unix(unix, named)?;
                Ok(Self {
                    unix: Some(listener),
                    tcp,
                    stdio: false,
                    _socket: Some(socket),
                })
            }
        }
    }

    /// The token file TCP clients read, when TCP is on.
    pub fn token_path(&self) -> Option<&Path> {
        self.tcp.as_ref().map(|(_, t)| t.path.as_path())
    }
}

/// Where the token of the session at `socket` is: `SOCKET.token`.
pub fn token_path(socket: &Path) -> PathBuf {
    let mut p = socket.as_os_str().to_owned();
    p.push(".token");
    PathBuf::from(p)
}

/// Characters of a session's token: 128 bits, in hex.
pub const TOKEN_CHARS: usize = 32;

/// A fresh random token ([`TOKEN_CHARS`] hex digits) in `path`, mode 0600 from its
/// creation: whole or absent, never readable by another user.
fn write_token(path: &Path) -> anyhow::Result<Token> {
    use std::io::Read as _;
    let mut bytes = [0u8; TOKEN_CHARS / 2];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| anyhow::anyhow!("reading /dev/urandom: {}", crate::files::reason(&e)))?;
    let value: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    // The file is created under umask 077, so not even its empty first
    // moments are open to others; nothing else creates files meanwhile
    // (the session's threads start later).
    let old = nix::sys::stat::umask(nix::sys::stat::Mode::from_bits_truncate(0o077));
    let written = crate::files::write_whole(path, format!("{value}\n").as_bytes());
    nix::sys::stat::umask(old);
    written?;
    let token = Token {
        path: path.to_owned(),
        value,
    };
    // Belt and braces: the mode is checked, not assumed.
    let mode = std::fs::metadata(path)
        .map(|m| m.permissions().mode() & 0o777)
        .unwrap_or(0);
    anyhow::ensure!(
        mode == 0o600,
        "the token file {} has mode {mode:o}, not 600",
        path.display()
    );
    Ok(token)
}

/// Errors unless `path` may be bound: short enough, and nothing there but
/// the socket of a session that died (removed).
fn free_unix(path: &Path, named: &str) -> anyhow::Result<()> {
    use std::os::unix::net::UnixStream;
    let len = path.as_os_str().len();
    if len > MAX_SOCKET_PATH_BYTES {
        return Err(InputError::new(format!(
            "{named} {}: a socket path is at most {MAX_SOCKET_PATH_BYTES} bytes, this one is {len}; give a shorter path",
            path.display()
        ))
        .into());
    }
    if std::fs::symlink_metadata(path).is_ok() {
        if UnixStream::connect(path).is_ok() {
            return Err(InputError::new(format!(
                "{named} {}: another session listens there",
                path.display()
            ))
            .into());
        }
        let is_socket = std::fs::symlink_metadata(path).is_ok_and(|m| {
            use std::os::unix::fs::FileTypeExt as _;
            m.file_type().is_socket()
        });
        if !is_socket {
            return Err(InputError::new(format!(
                "{named} {}: exists and is not a socket; give a new path",
                path.display()
            ))
            .into());
        }
        // A socket no one listens on: a session that died.
        std::fs::remove_file(path)
            .map_err(|e| anyhow::anyhow!("removing the stale socket {}: {e}", path.display()))?;
    }
    Ok(())
}

/// Binds the control socket at `path` ([`free_unix`] first), mode 0600.
fn bind_unix(
    path: &Path,
    named: &str,
) -> anyhow::Result<(std::os::unix::net::UnixListener, UnixSocket)> {
    use std::os::unix::net::UnixListener;
    let l = UnixListener::bind(path)
        .map_err(|e| anyhow::anyhow!("{named} {}: {}", path.display(), crate::files::reason(&e)))?;
    let guard = UnixSocket {
        path: path.to_owned(),
    };
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600))
        .map_err(|e| anyhow::anyhow!("{named} {}: {}", path.display(), crate::files::reason(&e)))?;
    Ok((l, guard))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> crate::files::Scratch {
        crate::files::scratch(&format!("endpoint-{name}"))
    }

    #[test]
    fn the_default_socket_stays_in_tmp_whatever_user_says() {
        let path = |u: Option<&str>| user_socket(u, 1000).0;
        assert_eq!(path(Some("ana")), Path::new("/tmp/lmhost-ana.sock"));
        for odd in [
            None,
            Some("../../etc/x"),
            Some("a/b"),
            Some(".."),
            Some("."),
            Some("a\0b"),
        ] {
            assert_eq!(path(odd), Path::new("/tmp/lmhost-1000.sock"), "{odd:?}");
        }
    }

    #[test]
    fn a_socket_path_too_long_is_bad_input_in_plain_words() {
        let p = PathBuf::from(format!("/tmp/{}", "s".repeat(200)));
        let e = Endpoint::bind(&Control::Socket {
            unix: p,
            tcp: None,
            named: "--control".into(),
        })
        .err()
        .unwrap();
        assert!(e.is::<InputError>(), "{e}");
        let m = e.to_string();
        assert!(m.contains("at most 107 bytes, this one is 205"), "{m}");
        assert!(!m.contains("SUN_LEN"), "{m}");
    }

    #[test]
    fn tcp_writes_a_private_token_and_removes_it_with_the_socket() {
        let d = scratch("token");
        let sock = d.join("s.sock");
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let port = l.local_addr().unwrap().port();
        drop(l);
        let e = Endpoint::bind(&Control::Socket {
            unix: sock.clone(),
            tcp: Some(port),
            named: "--control".into(),
        })
        .unwrap();
        let tp = e.token_path().unwrap().to_owned();
        assert_eq!(tp, d.join("s.sock.token"));
        let mode = std::fs::metadata(&tp).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        let text = std::fs::read_to_string(&tp).unwrap();
        let t = &e.tcp.as_ref().unwrap().1;
        assert!(t.matches(text.trim()) && text.trim().len() == 32);
        assert!(!t.matches("") && !t.matches(&"0".repeat(32)));
        drop(e);
        assert!(!tp.exists() && !sock.exists());
        let _ = std::fs::remove_dir_all(&d);
    }
}
