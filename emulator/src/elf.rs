//! The firmware image: the release ELF's loadable segments at their load
//! addresses (what a probe writes to flash), its entry symbols and its
//! defmt table.

use object::elf::PT_LOAD;
use object::read::elf::{ElfFile32, ProgramHeader};
use object::{Endianness, Object, ObjectSymbol};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// Where `cargo fw` puts the release firmware, relative to the workspace root.
pub const RELEASE_ELF: &str = "target/thumbv7m-none-eabi/release/firmware";

/// Why a firmware image could not be used.
#[derive(Debug)]
pub enum ElfError {
    /// The file could not be read.
    Io(PathBuf, std::io::Error),
    /// Not a 32-bit little-endian ARM ELF.
    Format(String),
    /// A loadable segment lies outside flash.
    SegmentOutsideFlash {
        /// Load address.
        address: u32,
        /// Bytes.
        len: usize,
    },
    /// A symbol the board needs is absent.
    MissingSymbol(&'static str),
    /// The ELF has no defmt table (not a defmt firmware).
    NoDefmtTable(String),
}

impl std::fmt::Display for ElfError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io(p, e) => write!(f, "cannot read firmware ELF {}: {e}", p.display()),
            Self::Format(e) => write!(f, "not a Cortex-M ELF: {e}"),
            Self::SegmentOutsideFlash { address, len } => write!(
                f,
                "loadable segment at {address:#010x} ({len} bytes) is outside the chip's flash"
            ),
            Self::MissingSymbol(s) => write!(f, "symbol `{s}` not found in the ELF"),
            Self::NoDefmtTable(e) => write!(f, "no usable defmt table in the ELF: {e}"),
        }
    }
}

impl std::error::Error for ElfError {}

/// Flash base (RM0008 §3.3.3, table 5: main memory block).
pub const FLASH_BASE: u32 = 0x0800_0000;
/// Flash size of the STM32F103C8 (medium density, 64 KiB): the board's
/// unless the ELF says otherwise ([`chip_flash_size`]).
pub const FLASH_SIZE: u32 = 64 * 1024;
/// Flash size of the STM32F103CB (medium density, 128 KiB).
pub const FLASH_SIZE_CB: u32 = 128 * 1024;

/// The flash size of the chip an ELF was linked for: its linker script's
/// `_flash_chip_end` (`memory.x`, `memory-cb.x`) when it is one of the
/// two medium-density sizes, else the C8's.
pub fn chip_flash_size(symbols: &HashMap<String, u32>) -> u32 {
    match symbols
        .get("_flash_chip_end")
        .map(|e| e.wrapping_sub(FLASH_BASE))
    {
        Some(FLASH_SIZE_CB) => FLASH_SIZE_CB,
        _ => FLASH_SIZE,
    }
}

/// A firmware image ready to be "flashed" onto the emulated board.
pub struct Firmware {
    /// Flash contents as programmed by a probe (erased bytes are 0xFF).
    pub flash: Vec<u8>,
    /// Address of the `_SEGGER_RTT` control block in RAM.
    pub rtt_address: u32,
    /// Highest flash address holding code or data, exclusive.
    pub image_end: u32,
    /// The defmt table (shared by every board running the same file);
    /// `None` for a bare image (nothing is decoded).
    pub table: Option<&'static defmt_decoder::Table>,
    /// Symbol addresses (functions with the Thumb bit cleared), for reports.
    pub symbols: HashMap<String, u32>,
}

impl Firmware {
    /// Loads the ELF at `path`.
    pub fn load(path: &Path) -> Result<Self, ElfError> {
        let data = std::fs::read(path).map_err(|e| ElfError::Io(path.to_owned(), e))?;
        Self::parse(&data)
    }

    /// Parses an ELF image in memory.
    pub fn parse(data: &[u8]) -> Result<Self, ElfError> {
        let elf =
            ElfFile32::<Endianness>::parse(data).map_err(|e| ElfError::Format(e.to_string()))?;
        let e = elf.endian();
        let mut symbols = HashMap::new();
        for s in elf.symbols() {
            if let Ok(name) = s.name() {
                if !name.is_empty() {
                    symbols.insert(name.to_owned(), (s.address() as u32) & !1);
                }
            }
        }
        let mut flash = vec![0xFF; chip_flash_size(&symbols) as usize];
        let mut image_end = FLASH_BASE;
        for ph in elf.elf_program_headers() {
            if ph.p_type(e) != PT_LOAD || ph.p_filesz(e) == 0 {
                continue;
            }
            let bytes = ph
                .data(e, data)
                .map_err(|_| ElfError::Format("bad segment".into()))?;
            let address = ph.p_paddr(e);
            let start = address.wrapping_sub(FLASH_BASE) as usize;
            let slot = flash
                .get_mut(start..start.saturating_add(bytes.len()))
                .filter(|_| address >= FLASH_BASE)
                .ok_or(ElfError::SegmentOutsideFlash {
                    address,
                    len: bytes.len(),
                })?;
            slot.copy_from_slice(bytes);
            image_end = image_end.max(address + bytes.len() as u32);
        }
        let rtt_address = *symbols
            .get("_SEGGER_RTT")
            .ok_or(ElfError::MissingSymbol("_SEGGER_RTT"))?;
        let table = Some(table_for(data)?);
        Ok(Self {
            flash,
            rtt_address,
            image_end,
            table,
            symbols,
        })
    }
}

/// The defmt table of `elf`, parsed once per distinct file and kept for the
/// life of the process: the stream decoder borrows its table, and a board
/// (re)starts decoders at every MCU reset, so the table must outlive them.
fn table_for(elf: &[u8]) -> Result<&'static defmt_decoder::Table, ElfError> {
    use std::hash::{Hash, Hasher};
    static TABLES: OnceLock<Mutex<HashMap<u64, &'static defmt_decoder::Table>>> = OnceLock::new();
    let mut h = std::collections::hash_map::DefaultHasher::new();
    elf.hash(&mut h);
    let key = h.finish();
    let tables = TABLES.get_or_init(|| Mutex::new(HashMap::new()));
    let mut map = tables.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(t) = map.get(&key) {
        return Ok(t);
    }
    let table = defmt_decoder::Table::parse(elf)
        .map_err(|e| ElfError::NoDefmtTable(e.to_string()))?
        .ok_or_else(|| ElfError::NoDefmtTable(".defmt section missing".into()))?;
    let table: &'static defmt_decoder::Table = Box::leak(Box::new(table));
    map.insert(key, table);
    Ok(table)
}

/// The workspace root (the emulator crate's parent directory).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Path of the release firmware ELF in this workspace.
pub fn release_elf_path() -> PathBuf {
    workspace_root().join(RELEASE_ELF)
}
