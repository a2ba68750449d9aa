//! `cargo xtask bitstream`: the iCE40-HX8K Breakout Board's bitstreams.
//!
//! A board's slice of the frame (`first`, `total`) lives in a block RAM
//! that the build stamps after place and route (`gateware/hx8k.py`,
//! `lmdriver.SliceRom`), so the netlist depends on the channel count
//! alone: each distinct channel count is synthesised, placed and routed
//! once (the template), and each board is the template with its slice
//! written into the RAM by `icebram`, checked by stamping it back.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::ctx::Ctx;
use crate::proc::{Log, has_program, is_root};

fn run(cmd: &mut Command) -> Result<(), String> {
    crate::proc::run(&Log::Terminal, cmd)
}

/// Output pins of one breakout board (`hx8k.CHANNELS`).
const BOARD_CHANNELS: u16 = 64;
/// The design clock nextpnr is asked to meet: 40 kHz × 256 × 8.
const DESIGN_MHZ: f64 = 81.92;
/// Transducers of the paper's rig (`scenes/paper.toml`): `--all`'s default.
const PAPER_TOTAL: u16 = 996;

const USAGE: &str =
    "usage: cargo xtask bitstream [--channels N] [--first F] [--total T] | --all [--total T]";

/// One board of the array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Board {
    /// Position on the bus (`None` for a single board built alone).
    index: Option<usize>,
    first: u16,
    channels: u16,
    total: u16,
}

impl Board {
    fn name(&self) -> String {
        let last = self.first + self.channels - 1;
        match self.index {
            Some(i) => format!("hx8k_b{i:02}_{}-{last}_of_{}", self.first, self.total),
            None => format!("hx8k_{}-{last}_of_{}", self.first, self.total),
        }
    }

    fn label(&self) -> String {
        match self.index {
            Some(i) => format!(
                "board {i} (first {}, {} channels)",
                self.first, self.channels
            ),
            None => format!("board (first {}, {} channels)", self.first, self.channels),
        }
    }
}

/// `total` split into 64-channel boards, the last taking the remainder.
fn split(total: u16) -> Vec<Board> {
    (0..total)
        .step_by(usize::from(BOARD_CHANNELS))
        .enumerate()
        .map(|(i, first)| Board {
            index: Some(i),
            first,
            channels: BOARD_CHANNELS.min(total - first),
            total,
        })
        .collect()
}

fn parse_args(args: &[String]) -> Result<Vec<Board>, String> {
    let (mut all, mut channels, mut first, mut total) = (false, None, None, None);
    let mut rest = args.iter();
    while let Some(flag) = rest.next() {
        if flag == "--all" {
            all = true;
            continue;
        }
        let v = rest.next().and_then(|v| v.parse::<u16>().ok());
        match (flag.as_str(), v) {
            ("--channels", Some(v)) => channels = Some(v),
            ("--first", Some(v)) => first = Some(v),
            ("--total", Some(v)) => total = Some(v),
            _ => return Err(USAGE.into()),
        }
    }
    if all {
        if channels.is_some() || first.is_some() {
            return Err(format!(
                "--all splits the array into {BOARD_CHANNELS}-channel boards itself: no --channels or --first"
            ));
        }
        let total = total.unwrap_or(PAPER_TOTAL);
        if total == 0 {
            return Err("--total must be at least 1".into());
        }
        return Ok(split(total));
    }
    let channels = channels.unwrap_or(BOARD_CHANNELS);
    let first = first.unwrap_or(0);
    if channels == 0 || channels > BOARD_CHANNELS {
        return Err(format!(
            "--channels must be 1..={BOARD_CHANNELS} (the board's output pins)"
        ));
    }
    let end = u32::from(first) + u32::from(channels);
    let total = match total {
        Some(t) => t,
        None => u16::try_from(end).map_err(|_| "first + channels must be <= 65535".to_string())?,
    };
    if end > u32::from(total) {
        return Err(format!(
            "first {first} + channels {channels} must be <= total {total}"
        ));
    }
    Ok(vec![Board {
        index: None,
        first,
        channels,
        total,
    }])
}

/// What nextpnr reported for a template.
#[derive(Clone, Debug, Default, PartialEq)]
struct Pnr {
    cells: (u32, u32),
    io: (u32, u32),
    pll: (u32, u32),
    ram: (u32, u32),
    /// After routing (nextpnr reports it after placement too: the last counts).
    fmax_mhz: Option<f64>,
    /// The first ERROR line, if any.
    error: Option<String>,
}

/// `used/ available` from a line like `ICESTORM_LC:  3548/ 7680    46%`.
fn used_of(line: &str) -> Option<(u32, u32)> {
    let (_, rest) = line.split_once(':')?;
    let (used, rest) = rest.split_once('/')?;
    let avail = rest.split_whitespace().next()?;
    Some((used.trim().parse().ok()?, avail.parse().ok()?))
}

fn parse_log(text: &str) -> Pnr {
    let mut p = Pnr::default();
    for line in text.lines() {
        let l = line.trim_start_matches("Info:").trim();
        let slot = if l.starts_with("ICESTORM_LC:") {
            Some(&mut p.cells)
        } else if l.starts_with("SB_IO:") {
            Some(&mut p.io)
        } else if l.starts_with("ICESTORM_PLL:") {
            Some(&mut p.pll)
        } else if l.starts_with("ICESTORM_RAM:") {
            Some(&mut p.ram)
        } else {
            None
        };
        if let (Some(slot), Some(v)) = (slot, used_of(l)) {
            *slot = v;
        }
        if let Some(i) = l.find("Max frequency for clock") {
            // "... 'clk': 95.68 MHz (PASS at 81.92 MHz)"
            p.fmax_mhz = l[i..]
                .split_once("': ")
                .and_then(|(_, r)| r.split_whitespace().next())
                .and_then(|v| v.parse().ok());
        }
        if p.error.is_none() && line.starts_with("ERROR:") {
            p.error = Some(line.trim_start_matches("ERROR:").trim().to_string());
        }
    }
    p
}

/// The one-line verdict on a template: Ok, or why its boards cannot be used.
fn verdict(p: &Pnr, ok_exit: bool) -> Result<(), String> {
    match p.fmax_mhz {
        Some(f) if f < DESIGN_MHZ => Err(format!(
            "does not meet timing: {f:.2} MHz after routing, below the {DESIGN_MHZ} MHz design clock"
        )),
        _ if !ok_exit || p.error.is_some() => Err(format!(
            "does not fit or did not place and route: {}",
            p.error.as_deref().unwrap_or("nextpnr-ice40 failed")
        )),
        None => Err("nextpnr-ice40 reported no fmax".into()),
        Some(_) => Ok(()),
    }
}

/// Runs `cmd` with its output captured (a stdout the caller set is kept);
/// on failure, the command and its first stderr line.
fn quiet(cmd: &mut Command) -> Result<(), String> {
    let out = cmd
        .output()
        .map_err(|e| format!("cannot start {:?}: {e}", cmd.get_program()))?;
    if out.status.success() {
        return Ok(());
    }
    let err = String::from_utf8_lossy(&out.stderr);
    Err(format!(
        "{:?} failed ({}): {}",
        cmd.get_program(),
        out.status,
        err.lines().find(|l| !l.trim().is_empty()).unwrap_or("")
    ))
}

struct Template {
    channels: u16,
    asc: PathBuf,
    rom: PathBuf,
    pnr: Pnr,
    result: Result<(), String>,
    seconds: f64,
}

/// Synthesis, placement and routing of one channel count, ROM placeholder included.
fn template(c: &Ctx, python: &Path, out: &Path, channels: u16) -> Result<Template, String> {
    let t0 = Instant::now();
    let stem = format!("template_{channels}ch");
    let il = out.join(format!("{stem}.il"));
    let rom = out.join(format!("{stem}.rom.hex"));
    let json = out.join(format!("{stem}.json"));
    let asc = out.join(format!("{stem}.asc"));
    let log = out.join(format!("nextpnr_{stem}.log"));
    let _ = std::fs::remove_file(&asc);
    quiet(
        Command::new(python)
            .arg(c.root.join("gateware").join("hx8k.py"))
            .args(["--channels", &channels.to_string(), "--rom-hex"])
            .arg(&rom)
            .arg(&il)
            .env("PYTHONDONTWRITEBYTECODE", "1"),
    )?;
    quiet(Command::new("yosys").arg("-q").arg("-p").arg(format!(
        "read_rtlil {}; synth_ice40 -top top -json {}",
        il.display(),
        json.display()
    )))?;
    let status = Command::new("nextpnr-ice40")
        .args(["--hx8k", "--package", "ct256", "--freq", "81.92"])
        .arg("--pcf")
        .arg(c.root.join("gateware").join("ice40hx8k-b-evn.pcf"))
        .arg("--json")
        .arg(&json)
        .arg("--asc")
        .arg(&asc)
        .arg("--log")
        .arg(&log)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map_err(|e| format!("cannot start nextpnr-ice40: {e}"))?;
    let pnr = parse_log(&std::fs::read_to_string(&log).unwrap_or_default());
    let result = verdict(&pnr, status.success() && asc.exists())
        .map_err(|e| format!("{e} (see {})", log.display()));
    Ok(Template {
        channels,
        asc,
        rom,
        pnr,
        result,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// The template with the board's slice in its RAM, checked by stamping
/// it back (the result must be the template again, byte for byte), then
/// packed.
fn stamp(c: &Ctx, python: &Path, out: &Path, t: &Template, b: &Board) -> Result<PathBuf, String> {
    let name = b.name();
    let hex = out.join(format!("{name}.rom.hex"));
    let asc = out.join(format!("{name}.asc"));
    let bin = out.join(format!("{name}.bin"));
    quiet(
        Command::new(python)
            .arg(c.root.join("gateware").join("hx8k.py"))
            .args(["--stamp", "--channels", &b.channels.to_string()])
            .args([
                "--first",
                &b.first.to_string(),
                "--total",
                &b.total.to_string(),
            ])
            .arg(&hex)
            .env("PYTHONDONTWRITEBYTECODE", "1"),
    )?;
    let icebram = |from: &Path, to: &Path, src: &Path, dst: &Path| -> Result<(), String> {
        let input = std::fs::File::open(src).map_err(|e| format!("{}: {e}", src.display()))?;
        let output = std::fs::File::create(dst).map_err(|e| format!("{}: {e}", dst.display()))?;
        quiet(
            Command::new("icebram")
                .arg(from)
                .arg(to)
                .stdin(input)
                .stdout(output),
        )
        .map_err(|e| format!("icebram ({}): {e}", src.display()))
    };
    icebram(&t.rom, &hex, &t.asc, &asc)?;
    let back = out.join(format!("{name}.check.asc"));
    icebram(&hex, &t.rom, &asc, &back)?;
    let same = std::fs::read(&back).ok() == std::fs::read(&t.asc).ok();
    let _ = std::fs::remove_file(&back);
    if !same {
        return Err(format!(
            "{}: the stamped bitstream differs from its template outside the slice RAM",
            b.label()
        ));
    }
    quiet(Command::new("icepack").arg(&asc).arg(&bin))?;
    Ok(bin)
}

fn ensure_tools() -> Result<(), String> {
    let tools = ["yosys", "nextpnr-ice40", "icepack", "icebram"];
    if tools.iter().all(|t| has_program(t)) {
        return Ok(());
    }
    if !is_root() {
        return Err(
            "bitstream needs yosys, nextpnr-ice40, icepack and icebram: \
                    apt-get install -y yosys nextpnr-ice40 fpga-icestorm"
                .into(),
        );
    }
    run(Command::new("apt-get")
        .args(["install", "-y", "yosys", "nextpnr-ice40", "fpga-icestorm"])
        .env("DEBIAN_FRONTEND", "noninteractive"))
}

pub fn bitstream(c: &Ctx, args: &[String]) -> Result<(), String> {
    let boards = parse_args(args)?;
    ensure_tools()?;
    let python = c.target_dir.join("gw-venv").join("bin").join("python");
    if !python.exists() {
        return Err("run `cargo xtask gateware` first (it sets up the venv)".into());
    }
    let out = c.target_dir.join("gateware").join("bitstream");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let t0 = Instant::now();
    let mut counts: Vec<u16> = boards.iter().map(|b| b.channels).collect();
    counts.sort_unstable();
    counts.dedup();
    counts.reverse();
    println!(
        "{} board(s), {} distinct netlist(s) ({} channels): placing and routing each once{}",
        boards.len(),
        counts.len(),
        counts
            .iter()
            .map(u16::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        if counts.len() > 1 {
            ", in parallel"
        } else {
            ""
        }
    );
    let templates: Vec<Result<Template, String>> = std::thread::scope(|s| {
        let handles: Vec<_> = counts
            .iter()
            .map(|&n| {
                let (python, out) = (&python, &out);
                s.spawn(move || template(c, python, out, n))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err("a template build panicked".into()))
            })
            .collect()
    });
    let templates = templates.into_iter().collect::<Result<Vec<_>, _>>()?;
    for t in &templates {
        println!(
            "template {} channels: {:.0} s (yosys + nextpnr-ice40)",
            t.channels, t.seconds
        );
    }
    let mut rows = Vec::new();
    let mut failure = None;
    for b in &boards {
        // A failed build must not leave an older bitstream under the board's name.
        for ext in ["bin", "asc", "rom.hex"] {
            let _ = std::fs::remove_file(out.join(format!("{}.{ext}", b.name())));
        }
        let t = templates
            .iter()
            .find(|t| t.channels == b.channels)
            .expect("a template per channel count");
        let bin = match &t.result {
            Ok(()) => match stamp(c, &python, &out, t, b) {
                Ok(bin) => bin.file_name().map(|f| f.to_string_lossy().into_owned()),
                Err(e) => {
                    failure.get_or_insert(e);
                    None
                }
            },
            Err(e) => {
                failure.get_or_insert(format!("{}: {e}", b.label()));
                None
            }
        };
        rows.push((*b, t.pnr.clone(), bin));
    }
    print_table(&rows);
    println!(
        "{} bitstream(s) in {} ({:.0} s)",
        rows.iter().filter(|r| r.2.is_some()).count(),
        out.display(),
        t0.elapsed().as_secs_f64()
    );
    match failure {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn print_table(rows: &[(Board, Pnr, Option<String>)]) {
    println!(
        "| board | first | channels | logic cells | I/O | PLL | fmax after routing (81.92 MHz asked) | bitstream |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (b, p, bin) in rows {
        let fmax = match p.fmax_mhz {
            Some(f) if f >= DESIGN_MHZ => format!("{f:.2} MHz PASS"),
            Some(f) => format!("{f:.2} MHz FAIL"),
            None => "—".into(),
        };
        println!(
            "| {} | {} | {} | {} / {} ({:.0} %) | {} / {} | {} / {} | {fmax} | {} |",
            b.index.map_or("—".into(), |i| i.to_string()),
            b.first,
            b.channels,
            p.cells.0,
            p.cells.1,
            if p.cells.1 > 0 {
                100.0 * f64::from(p.cells.0) / f64::from(p.cells.1)
            } else {
                0.0
            },
            p.io.0,
            p.io.1,
            p.pll.0,
            p.pll.1,
            bin.as_deref().map_or("—".into(), |f| format!("`{f}`"))
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn the_paper_array_is_fifteen_full_boards_and_one_of_36() {
        let b = parse_args(&args(&["--all"])).unwrap();
        assert_eq!(b.len(), 16);
        assert!(
            b[..15]
                .iter()
                .enumerate()
                .all(|(i, b)| b.first == 64 * i as u16 && b.channels == 64 && b.total == 996)
        );
        assert_eq!((b[15].first, b[15].channels), (960, 36));
        assert_eq!(b[15].name(), "hx8k_b15_960-995_of_996");
        assert_eq!(
            parse_args(&args(&["--all", "--total", "128"]))
                .unwrap()
                .len(),
            2
        );
    }

    #[test]
    fn a_single_board_checks_its_slice() {
        let b = parse_args(&args(&[
            "--channels",
            "36",
            "--first",
            "960",
            "--total",
            "996",
        ]))
        .unwrap();
        assert_eq!(b[0].name(), "hx8k_960-995_of_996");
        assert!(parse_args(&args(&["--first", "960", "--total", "996"])).is_err());
        assert!(parse_args(&args(&["--channels", "65"])).is_err());
        assert!(parse_args(&args(&["--all", "--first", "3"])).is_err());
        assert_eq!(parse_args(&args(&[])).unwrap()[0].total, 64);
    }

    #[test]
    fn the_log_gives_cells_and_the_routed_fmax() {
        let log = "Info: \t         ICESTORM_LC:  3548/ 7680    46%\n\
                   Info: \t               SB_IO:    77/  256    30%\n\
                   Info: \t        ICESTORM_PLL:     1/    2    50%\n\
                   Info: Max frequency for clock 'clk': 73.99 MHz (FAIL at 81.92 MHz)\n\
                   Info: Max frequency for clock 'clk': 95.68 MHz (PASS at 81.92 MHz)\n";
        let p = parse_log(log);
        assert_eq!((p.cells, p.io, p.pll), ((3548, 7680), (77, 256), (1, 2)));
        assert_eq!(p.fmax_mhz, Some(95.68));
        assert!(verdict(&p, true).is_ok());
        let slow = parse_log(&log.replace("95.68 MHz (PASS", "76.16 MHz (FAIL"));
        assert!(
            verdict(&slow, false)
                .unwrap_err()
                .contains("does not meet timing")
        );
        let full = parse_log("ERROR: Unable to place cell 'x', no BELs remaining\n");
        assert!(verdict(&full, false).unwrap_err().contains("does not fit"));
    }
}
