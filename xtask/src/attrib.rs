//! Every flashed byte of the firmware ELF attributed to an [`Owner`] (crate
//! and module) and so to a feature [`Group`].
//!
//! The flashed sections (`.vector_table`, `.text`, `.rodata`, the load
//! image of `.data`) are swept symbol by symbol from the ELF symbol table
//! (aliases and overlaps: each byte goes to the first symbol covering it).
//! A function's bytes are then split by the DWARF line table: code inlined
//! from another module (with fat LTO, RTIC's dispatchers `SPI1`, `CAN_RX1`
//! hold whole tasks) goes to the module whose source it is; code inlined
//! from `core`/`alloc` stays with the function it was inlined into.
//! Bytes no symbol covers (padding, `.Lanon.*` constants) are
//! [`Group::Unattributed`]. The parts add up to the flash total exactly.

use crate::classify::{file_owner, symbol_owner, Group, Owner};
use object::{Object, ObjectSection, ObjectSymbol, SymbolKind};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;

/// One symbol's flashed bytes.
#[derive(Debug, Clone)]
pub struct SymbolBytes {
    /// Demangled name, without the hash suffix.
    pub name: String,
    /// Bytes of the symbol's own range (after removing overlaps).
    pub bytes: u64,
    /// Owner by the symbol's name.
    pub owner: Owner,
    /// Bytes per group after the line-table split, largest first.
    pub groups: Vec<(Group, u64)>,
}

/// The flash image attributed.
#[derive(Debug, Default)]
pub struct Attribution {
    /// Flashed bytes per owner (crate, module).
    pub by_owner: BTreeMap<Owner, u64>,
    /// Flashed bytes no symbol covers.
    pub unattributed: u64,
    /// The same per section name (`.rodata`: anonymous constants; `.text`:
    /// padding between functions).
    pub unattributed_by_section: BTreeMap<String, u64>,
    /// Every symbol with flashed bytes.
    pub symbols: Vec<SymbolBytes>,
    /// Sum of the flashed sections' sizes.
    pub total: u64,
    /// Linker-script symbols (`_flash_plan_*`, `_calib_*`): name → value.
    pub plan_symbols: BTreeMap<String, u64>,
}

impl Attribution {
    /// Flashed bytes per group ([`Group::Unattributed`] included).
    pub fn by_group(&self) -> BTreeMap<Group, u64> {
        let mut out: BTreeMap<Group, u64> = Group::ALL.iter().map(|g| (*g, 0)).collect();
        for (owner, bytes) in &self.by_owner {
            *out.entry(owner.group()).or_default() += bytes;
        }
        *out.entry(Group::Unattributed).or_default() += self.unattributed;
        out
    }
}

/// A flashed section: its address range in the ELF's view (`.data` at its
/// RAM address; its bytes are flashed at the load address).
struct FlashSection {
    name: String,
    start: u64,
    end: u64,
}

/// A symbol candidate inside a flashed section.
struct Sym {
    start: u64,
    end: u64,
    name: String,
    func: bool,
}

/// Same rule as `elf_sizes`: an allocated section at a flash address, or
/// `.data` (its initial values are flashed).
fn flash_sections(file: &object::File) -> Vec<FlashSection> {
    let mut out = Vec::new();
    for s in file.sections() {
        let (addr, size) = (s.address(), s.size());
        let name = s.name().unwrap_or("");
        let in_flash = (0x0800_0000..0x0810_0000).contains(&addr);
        if addr == 0 || size == 0 || !(in_flash || name == ".data") {
            continue;
        }
        out.push(FlashSection {
            name: name.to_string(),
            start: addr,
            end: addr + size,
        });
    }
    out
}

/// Sized symbols of the ELF, Thumb bit cleared, demangled.
fn symbols(file: &object::File) -> Vec<Sym> {
    let mut out = Vec::new();
    for s in file.symbols() {
        let func = s.kind() == SymbolKind::Text;
        if s.size() == 0 || !matches!(s.kind(), SymbolKind::Text | SymbolKind::Data) {
            continue;
        }
        let Ok(raw) = s.name() else { continue };
        let start = if func { s.address() & !1 } else { s.address() };
        out.push(Sym {
            start,
            end: start + s.size(),
            name: format!("{:#}", rustc_demangle::demangle(raw)),
            func,
        });
    }
    // Lowest address first; at one address the largest, then by name, so
    // aliases resolve the same way every run.
    out.sort_by(|a, b| {
        (a.start, std::cmp::Reverse(a.end), &a.name).cmp(&(
            b.start,
            std::cmp::Reverse(b.end),
            &b.name,
        ))
    });
    out
}

/// Attributes the flash image of the ELF at `path`.
pub fn attribute(path: &Path) -> Result<Attribution, String> {
    let data = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let file = object::File::parse(&*data).map_err(|e| format!("{}: {e}", path.display()))?;
    let lines = LineMap::read(&file)?;
    let syms = symbols(&file);
    let mut out = Attribution::default();
    for sec in flash_sections(&file) {
        out.total += sec.end - sec.start;
        let before = out.unattributed;
        sweep(&sec, &syms, &lines, &mut out);
        let gap = out.unattributed - before;
        if gap > 0 {
            *out.unattributed_by_section.entry(sec.name).or_default() += gap;
        }
    }
    for s in file.symbols() {
        let name = s.name().unwrap_or("");
        if name.starts_with("_flash_plan_")
            || name.starts_with("_calib_")
            || name.starts_with("_params_")
        {
            out.plan_symbols.insert(name.to_string(), s.address());
        }
    }
    Ok(out)
}

/// Assigns each byte of `sec` to the first symbol covering it.
fn sweep(sec: &FlashSection, syms: &[Sym], lines: &LineMap, out: &mut Attribution) {
    let mut cursor = sec.start;
    let first = syms.partition_point(|s| s.start < sec.start);
    for sym in syms[first..].iter().take_while(|s| s.start < sec.end) {
        let (start, end) = (sym.start.max(cursor), sym.end.min(sec.end));
        if end <= start {
            continue;
        }
        out.unattributed += start - cursor;
        cursor = end;
        if sym.name.starts_with(".L") {
            // Anonymous constants: no owner to name.
            out.unattributed += end - start;
            continue;
        }
        let owner = symbol_owner(&sym.name);
        let mut groups: BTreeMap<Group, u64> = BTreeMap::new();
        let split = if sym.func {
            lines.split(start, end)
        } else {
            vec![(None, end - start)]
        };
        for (file_owner, bytes) in split {
            let o = file_owner.unwrap_or_else(|| owner.clone());
            *groups.entry(o.group()).or_default() += bytes;
            *out.by_owner.entry(o).or_default() += bytes;
        }
        let mut groups: Vec<(Group, u64)> = groups.into_iter().collect();
        groups.sort_by_key(|(g, b)| (std::cmp::Reverse(*b), *g));
        out.symbols.push(SymbolBytes {
            name: sym.name.clone(),
            bytes: end - start,
            owner,
            groups,
        });
    }
    out.unattributed += sec.end - cursor;
}

/// Address ranges of the DWARF line table with the owner of their source
/// file (`None`: the file is `core`/`alloc`/`std` or not recognised, so the
/// enclosing function's owner applies).
#[derive(Default)]
struct LineMap {
    /// (start, end, owner index into `owners`), sorted by start.
    ranges: Vec<(u64, u64, Option<usize>)>,
    owners: Vec<Owner>,
}

type Reader<'a> = gimli::EndianSlice<'a, gimli::LittleEndian>;

impl LineMap {
    /// Reads every unit's line program; an ELF without DWARF gives an
    /// empty map (attribution by symbol only).
    fn read(file: &object::File) -> Result<LineMap, String> {
        let load = |id: gimli::SectionId| -> Result<Cow<[u8]>, gimli::Error> {
            Ok(file
                .section_by_name(id.name())
                .and_then(|s| s.uncompressed_data().ok())
                .unwrap_or(Cow::Borrowed(&[])))
        };
        let sections = gimli::DwarfSections::load(load).map_err(|e| format!("DWARF: {e}"))?;
        let dwarf = sections.borrow(|s| gimli::EndianSlice::new(s, gimli::LittleEndian));
        let mut map = LineMap::default();
        let mut units = dwarf.units();
        while let Some(header) = units.next().map_err(|e| format!("DWARF: {e}"))? {
            let unit = dwarf.unit(header).map_err(|e| format!("DWARF: {e}"))?;
            map.read_unit(&dwarf, &unit)
                .map_err(|e| format!("DWARF line table: {e}"))?;
        }
        map.ranges.sort_unstable();
        Ok(map)
    }

    /// One unit's rows as ranges up to the next row's address.
    fn read_unit(
        &mut self,
        dwarf: &gimli::Dwarf<Reader>,
        unit: &gimli::Unit<Reader>,
    ) -> gimli::Result<()> {
        let Some(program) = unit.line_program.clone() else {
            return Ok(());
        };
        let mut cache: BTreeMap<u64, Option<usize>> = BTreeMap::new();
        let mut rows = program.rows();
        let mut open: Option<(u64, Option<usize>)> = None;
        while let Some((header, row)) = rows.next_row()? {
            if let Some((start, owner)) = open.take() {
                if row.address() > start && start != 0 {
                    self.ranges.push((start, row.address(), owner));
                }
            }
            if row.end_sequence() {
                continue;
            }
            let owner = match cache.get(&row.file_index()) {
                Some(o) => *o,
                None => {
                    let o = self.file_owner_index(dwarf, unit, header, row)?;
                    cache.insert(row.file_index(), o);
                    o
                }
            };
            open = Some((row.address(), owner));
        }
        Ok(())
    }

    /// The owner index of a row's file, interned.
    fn file_owner_index(
        &mut self,
        dwarf: &gimli::Dwarf<Reader>,
        unit: &gimli::Unit<Reader>,
        header: &gimli::LineProgramHeader<Reader>,
        row: &gimli::LineRow,
    ) -> gimli::Result<Option<usize>> {
        let Some(file) = row.file(header) else {
            return Ok(None);
        };
        let mut path = dwarf
            .attr_string(unit, file.path_name())?
            .to_string_lossy()
            .into_owned();
        if !path.starts_with('/') {
            if let Some(dir) = file.directory(header) {
                path = format!("{}/{path}", dwarf.attr_string(unit, dir)?.to_string_lossy());
            }
        }
        if !path.starts_with('/') {
            if let Some(comp_dir) = &unit.comp_dir {
                path = format!("{}/{path}", comp_dir.to_string_lossy());
            }
        }
        let Some(owner) = file_owner(&path) else {
            return Ok(None);
        };
        if matches!(owner.krate.as_str(), "core" | "alloc" | "std") {
            return Ok(None);
        }
        let index = match self.owners.iter().position(|o| *o == owner) {
            Some(i) => i,
            None => {
                self.owners.push(owner);
                self.owners.len() - 1
            }
        };
        Ok(Some(index))
    }

    /// `[start, end)` split by the line table's owners; bytes no row covers
    /// come back with `None`. A row of `core`/`alloc` code goes to the
    /// nearest preceding row's owner in the range (the function it was most
    /// likely inlined into), or `None` at the range's start.
    fn split(&self, start: u64, end: u64) -> Vec<(Option<Owner>, u64)> {
        let mut out: Vec<(Option<Owner>, u64)> = Vec::new();
        let mut covered = 0;
        let mut last = None;
        let first = self.ranges.partition_point(|r| r.1 <= start);
        for &(s, e, owner) in self.ranges[first..].iter().take_while(|r| r.0 < end) {
            let (s, e) = (s.max(start), e.min(end));
            if e <= s {
                continue;
            }
            covered += e - s;
            last = owner.or(last);
            out.push((last.map(|i| self.owners[i].clone()), e - s));
        }
        // Overlapping rows (two units claiming one address) must not count
        // bytes twice: fall back to the symbol's owner for the whole range.
        if covered > end - start {
            return vec![(None, end - start)];
        }
        out.push((None, end - start - covered));
        out
    }
}
