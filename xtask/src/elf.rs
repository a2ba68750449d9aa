//! Just enough of ELF32 (little-endian) to print a firmware memory map:
//! allocated sections and the RAM symbols, without cargo-binutils.

use std::fmt::Write;

/// Cortex-M SRAM region (QEMU's SSRAM2&3 at 0x2000_0000, the H743's DTCM
/// and AXI SRAM at 0x2000_0000 / 0x2400_0000); code sits below it.
const RAM: std::ops::Range<u32> = 0x2000_0000..0x4000_0000;
/// Symbols whose (demangled) name contains one of these hold the sequence
/// store: the slots the board gives the core.
const STORE_MARKERS: &[&str] = &["SEQUENCE_STORE", "SLOT_MEM", "STORE"];
/// RAM sections are grouped by the 16 MiB window they start in: one
/// memory per window on these chips (H743: DTCM at 0x2000_0000, AXI SRAM
/// at 0x2400_0000).
const WINDOW: u32 = 0xFF00_0000;

struct Section {
    name: String,
    kind: u32,
    flags: u32,
    addr: u32,
    offset: u32,
    size: u32,
    link: u32,
}

struct Symbol {
    name: String,
    addr: u32,
    size: u32,
    is_object: bool,
}

fn u16_at(b: &[u8], at: usize) -> Result<u16, String> {
    b.get(at..at + 2)
        .map(|s| u16::from_le_bytes([s[0], s[1]]))
        .ok_or_else(|| "truncated ELF file".to_string())
}

fn u32_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4)
        .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
        .ok_or_else(|| "truncated ELF file".to_string())
}

fn cstr_at(b: &[u8], at: usize) -> String {
    let tail = b.get(at..).unwrap_or(&[]);
    let end = tail.iter().position(|&c| c == 0).unwrap_or(tail.len());
    String::from_utf8_lossy(&tail[..end]).into_owned()
}

fn sections(b: &[u8]) -> Result<Vec<Section>, String> {
    if b.get(..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF file".into());
    }
    let shoff = u32_at(b, 0x20)? as usize;
    let shentsize = u16_at(b, 0x2E)? as usize;
    let shnum = u16_at(b, 0x30)? as usize;
    let shstrndx = u16_at(b, 0x32)? as usize;
    let raw = |i: usize| -> Result<Section, String> {
        let h = shoff + i * shentsize;
        Ok(Section {
            name: String::new(),
            kind: u32_at(b, h + 4)?,
            flags: u32_at(b, h + 8)?,
            addr: u32_at(b, h + 12)?,
            offset: u32_at(b, h + 16)?,
            size: u32_at(b, h + 20)?,
            link: u32_at(b, h + 24)?,
        })
    };
    let names = raw(shstrndx)?.offset as usize;
    (0..shnum)
        .map(|i| {
            let name_off = u32_at(b, shoff + i * shentsize)? as usize;
            Ok(Section {
                name: cstr_at(b, names + name_off),
                ..raw(i)?
            })
        })
        .collect()
}

fn symbols(b: &[u8], secs: &[Section]) -> Result<Vec<Symbol>, String> {
    const SHT_SYMTAB: u32 = 2;
    let Some(symtab) = secs.iter().find(|s| s.kind == SHT_SYMTAB) else {
        return Ok(Vec::new());
    };
    let strtab = secs
        .get(symtab.link as usize)
        .ok_or("symbol table links to a missing string table")?;
    let str_off = strtab.offset as usize;
    let mut out = Vec::new();
    for i in 0..symtab.size as usize / 16 {
        let e = symtab.offset as usize + i * 16;
        let name = u32_at(b, e)?;
        let value = u32_at(b, e + 4)?;
        let size = u32_at(b, e + 8)?;
        let info = *b.get(e + 12).ok_or("truncated symbol table")?;
        out.push(Symbol {
            name: demangle(&cstr_at(b, str_off + name as usize)),
            addr: value,
            size,
            is_object: info & 0xF == 1,
        });
    }
    Ok(out)
}

/// Legacy Rust mangling (`_ZN3foo3bar17h0123456789abcdefE`) to `foo::bar`;
/// anything else is returned as is.
fn demangle(s: &str) -> String {
    let Some(mut rest) = s.strip_prefix("_ZN") else {
        return s.to_string();
    };
    let mut parts = Vec::new();
    while let Some(n_len) = rest.find(|c: char| !c.is_ascii_digit()).filter(|&n| n > 0) {
        let Ok(n) = rest[..n_len].parse::<usize>() else {
            break;
        };
        let Some(part) = rest.get(n_len..n_len + n) else {
            break;
        };
        parts.push(part);
        rest = &rest[n_len + n..];
    }
    if parts
        .last()
        .is_some_and(|p| p.len() == 17 && p.starts_with('h'))
    {
        parts.pop();
    }
    if parts.is_empty() {
        s.to_string()
    } else {
        parts.join("::")
    }
}

/// The memory map report: allocated sections, flash/RAM totals, the largest
/// RAM objects, RAM per memory, and static RAM beside the sequence store.
pub fn memory_map(b: &[u8]) -> Result<String, String> {
    const SHF_ALLOC: u32 = 2;
    const SHT_NOBITS: u32 = 8;
    let secs = sections(b)?;
    let mut r = String::new();
    let (mut flash, mut ram) = (0u64, 0u64);
    writeln!(
        r,
        "{:<16} {:>10} {:>10}  region",
        "section", "address", "bytes"
    )
    .unwrap();
    for s in secs
        .iter()
        .filter(|s| s.flags & SHF_ALLOC != 0 && s.size > 0)
    {
        let in_ram = RAM.contains(&s.addr);
        let region = if in_ram { "RAM" } else { "code" };
        if in_ram {
            ram += u64::from(s.size);
            if s.kind != SHT_NOBITS {
                flash += u64::from(s.size); // .data's initial image lives in code memory
            }
        } else {
            flash += u64::from(s.size);
        }
        writeln!(
            r,
            "{:<16} {:#010x} {:>10}  {region}",
            s.name, s.addr, s.size
        )
        .unwrap();
    }
    writeln!(r, "code memory used: {flash} bytes").unwrap();
    writeln!(
        r,
        "static RAM (.data + .bss + .uninit + board sections): {ram} bytes (the stack takes the rest of its RAM)"
    )
    .unwrap();
    // Per memory (a board may place statics in more than one: the Nucleo's
    // DTCM and AXI SRAM), by the 16 MiB window they start in.
    let mut windows: Vec<(u32, u64)> = Vec::new();
    for s in secs
        .iter()
        .filter(|s| s.flags & SHF_ALLOC != 0 && s.size > 0 && RAM.contains(&s.addr))
    {
        let w = s.addr & WINDOW;
        match windows.iter_mut().find(|(a, _)| *a == w) {
            Some((_, n)) => *n += u64::from(s.size),
            None => windows.push((w, u64::from(s.size))),
        }
    }
    if windows.len() > 1 {
        for (w, n) in &windows {
            writeln!(r, "  in RAM from {w:#010x}: {n} bytes").unwrap();
        }
    }

    let mut objs: Vec<Symbol> = symbols(b, &secs)?
        .into_iter()
        .filter(|s| s.is_object && s.size > 0 && RAM.contains(&s.addr))
        .collect();
    objs.sort_by(|a, b| b.size.cmp(&a.size).then(a.name.cmp(&b.name)));
    let is_store = |s: &Symbol| STORE_MARKERS.iter().any(|m| s.name.contains(m));
    let store: u64 = objs
        .iter()
        .filter(|s| is_store(s))
        .map(|s| u64::from(s.size))
        .sum();
    writeln!(r, "largest RAM objects:").unwrap();
    for s in objs.iter().take(12) {
        let tag = if is_store(s) {
            "  (sequence store)"
        } else {
            ""
        };
        writeln!(r, "  {:>10}  {}{tag}", s.size, s.name).unwrap();
    }
    writeln!(r, "sequence store: {store} bytes").unwrap();
    // What shares the store's memory with it (the target keeps the
    // Nucleo's 512 KiB AXI SRAM from overflowing).
    let store_window = objs.iter().find(|s| is_store(s)).map(|s| s.addr & WINDOW);
    let beside = windows
        .iter()
        .filter(|(w, _)| Some(*w) == store_window || store_window.is_none())
        .map(|(_, n)| n)
        .sum::<u64>()
        - store;
    writeln!(
        r,
        "static RAM beside the sequence store, in its memory: {beside} bytes (target <= 16384)"
    )
    .unwrap();
    Ok(r)
}

/// The interrupts of `irqs` (number, name) whose vector-table entry is
/// cortex-m-rt's `DefaultHandler`, i.e. that have no handler of their own
/// linked in. An error if the ELF has no vector table or `DefaultHandler`.
pub fn unbound_interrupts<'a>(b: &[u8], irqs: &[(u32, &'a str)]) -> Result<Vec<&'a str>, String> {
    let secs = sections(b)?;
    let vt = secs
        .iter()
        .find(|s| s.name == ".vector_table")
        .ok_or("no .vector_table section")?;
    let default = symbols(b, &secs)?
        .iter()
        .find(|s| s.name == "DefaultHandler")
        .map(|s| s.addr & !1)
        .ok_or("no DefaultHandler symbol")?;
    let mut unbound = Vec::new();
    for &(n, name) in irqs {
        // 16 exception entries, then one word per interrupt.
        let at = (16 + n as usize) * 4;
        if at + 4 > vt.size as usize {
            return Err(format!("IRQ {n} ({name}) is beyond the vector table"));
        }
        let handler = u32_at(b, vt.offset as usize + at)? & !1;
        if handler == default || handler == 0 {
            unbound.push(name);
        }
    }
    Ok(unbound)
}

/// The address of the symbol named `name`, if the ELF has it.
pub fn symbol_address(b: &[u8], name: &str) -> Result<Option<u32>, String> {
    let secs = sections(b)?;
    Ok(symbols(b, &secs)?
        .iter()
        .find(|s| s.name == name)
        .map(|s| s.addr))
}

/// Whether the ELF has a section named `name`.
pub fn has_section(b: &[u8], name: &str) -> Result<bool, String> {
    Ok(sections(b)?.iter().any(|s| s.name == name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demangles_legacy_paths() {
        assert_eq!(
            demangle("_ZN10lm_fw_qemu5STORE17h0123456789abcdefE"),
            "lm_fw_qemu::STORE"
        );
        assert_eq!(demangle("main"), "main");
    }

    #[test]
    fn rejects_non_elf() {
        assert!(memory_map(b"not an elf").is_err());
        assert!(memory_map(&[0x7f, b'E', b'L', b'F', 1, 1, 0]).is_err());
    }
}
