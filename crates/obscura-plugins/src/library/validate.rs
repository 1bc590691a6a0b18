//! Checks a plugin library's file before the system loader sees it.
//!
//! `dlopen` trusts the file it is handed: a library cut short while copying maps pages past the end of
//! the file and dies of `SIGBUS` on first touch; an entry symbol that names data or garbage is called
//! and crashes. Neither can be caught once it has happened, so [`validate`] reads the file itself
//! (with the `object` crate) and refuses, naming the file and the reason:
//!
//! 1. **file type**: an empty file, a text file, a static archive, a Mach-O or PE file (foreign on
//!    an ELF system), or anything not starting with the ELF magic;
//! 2. **ELF identity**: the class (32/64-bit), data encoding (byte order) and version of the host; the
//!    type a shared library (`ET_DYN`, not an object file or executable);
//! 3. **architecture**: `e_machine` is the host's;
//! 4. **size**: the program headers, every segment's file bytes, the section headers and every
//!    section's file bytes lie within the file (a truncated file fails here); a dynamic segment exists;
//! 5. **the entry point**: `obscura_projection_entry` is defined in the dynamic symbol table as a
//!    function (`STT_FUNC`, or `STT_GNU_IFUNC`) whose address lies inside an executable section.
//!
//! A library without section headers (stripped with `sstrip`) cannot have its entry symbol read this
//! way; it passes on the first four checks and the loader finds the symbol (see docs/decisions.md).
//! What validation cannot see — a constructor that aborts, an entry point that crashes when called — is
//! what `--isolate-plugins` is for (see [`crate::isolate`]).
//!
//! On macOS and Windows only the file type is checked (an ELF file is named as foreign there).

use std::path::Path;

use object::elf;
use object::read::elf::{FileHeader, ProgramHeader, SectionHeader, Sym};
use obscura_sdk::abi::ENTRY_SYMBOL;

use super::PluginLoadError;

/// The object format this host's loader takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Elf,
    MachO,
    Pe,
}

impl Kind {
    const HOST: Kind = if cfg!(target_os = "macos") {
        Kind::MachO
    } else if cfg!(windows) {
        Kind::Pe
    } else {
        Kind::Elf
    };

    fn describe(self) -> &'static str {
        match self {
            Kind::Elf => "an ELF file (Linux, BSD)",
            Kind::MachO => "a Mach-O file (macOS)",
            Kind::Pe => "a PE file (a Windows DLL or executable)",
        }
    }

    fn host_library(self) -> &'static str {
        match self {
            Kind::Elf => "ELF shared libraries",
            Kind::MachO => "Mach-O dynamic libraries",
            Kind::Pe => "Windows DLLs",
        }
    }
}

/// Checks the library at `path` as described in the module doc, before it is opened.
///
/// # Errors
/// [`PluginLoadError::Refused`] naming the file and what is wrong with it, or
/// [`PluginLoadError::MissingSymbol`] when the entry point is not in its dynamic symbol table.
pub fn validate(path: &Path) -> Result<(), PluginLoadError> {
    let data = std::fs::read(path).map_err(|e| PluginLoadError::Open {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    check_bytes(&data).map_err(|e| match e {
        Problem::Refused(reason) => PluginLoadError::Refused {
            path: path.to_path_buf(),
            reason,
        },
        Problem::NoEntry(reason) => PluginLoadError::MissingSymbol {
            path: path.to_path_buf(),
            reason,
        },
    })
}

/// What [`check_bytes`] found wrong.
#[derive(Debug, Clone, PartialEq)]
enum Problem {
    /// The file is not a loadable library of this host.
    Refused(String),
    /// The entry symbol is not exported.
    NoEntry(String),
}

fn refuse<T>(reason: String) -> Result<T, Problem> {
    Err(Problem::Refused(reason))
}

/// [`validate`] on the file's bytes.
fn check_bytes(data: &[u8]) -> Result<(), Problem> {
    let kind = sniff(data)?;
    if kind != Kind::HOST {
        return refuse(format!(
            "it is {}, and this host loads {}",
            kind.describe(),
            Kind::HOST.host_library()
        ));
    }
    if kind != Kind::Elf {
        return Ok(());
    }
    check_elf(data)
}

/// The file's object format from its first bytes, or why it has none.
fn sniff(data: &[u8]) -> Result<Kind, Problem> {
    const MACHO: [[u8; 4]; 5] = [
        [0xfe, 0xed, 0xfa, 0xce],
        [0xce, 0xfa, 0xed, 0xfe],
        [0xfe, 0xed, 0xfa, 0xcf],
        [0xcf, 0xfa, 0xed, 0xfe],
        [0xca, 0xfe, 0xba, 0xbe],
    ];
    if data.is_empty() {
        return refuse("the file is empty (0 bytes), not a shared library".into());
    }
    if data.starts_with(&elf::ELFMAG) {
        return Ok(Kind::Elf);
    }
    if data.len() >= 4 && MACHO.iter().any(|m| data.starts_with(m)) {
        return Ok(Kind::MachO);
    }
    if data.starts_with(b"MZ") {
        return Ok(Kind::Pe);
    }
    if data.starts_with(b"!<arch>\n") {
        return refuse(
            "it is a static library archive (.a), not a shared library: link the plugin with -shared".into(),
        );
    }
    let head = &data[..data.len().min(512)];
    if let Ok(text) = std::str::from_utf8(head)
        && text.chars().all(|c| !c.is_control() || c.is_whitespace())
    {
        let first: String = text.lines().next().unwrap_or("").chars().take(40).collect();
        return refuse(format!(
            "it is a text file (it starts \"{}\"), not a shared library",
            first.escape_default()
        ));
    }
    let magic: Vec<String> = data.iter().take(4).map(|b| format!("{b:02x}")).collect();
    refuse(format!(
        "it is not a shared library: it starts with the bytes {} where an ELF file has 7f 45 4c 46",
        magic.join(" ")
    ))
}

/// The ELF header type of this host's class and byte order.
#[cfg(target_pointer_width = "64")]
type Header = elf::FileHeader64<object::Endianness>;
#[cfg(not(target_pointer_width = "64"))]
type Header = elf::FileHeader32<object::Endianness>;

/// The host's `ELFCLASS*`.
const HOST_CLASS: u8 = if cfg!(target_pointer_width = "64") {
    elf::ELFCLASS64
} else {
    elf::ELFCLASS32
};

/// The host's `ELFDATA*`.
const HOST_DATA: u8 = if cfg!(target_endian = "little") {
    elf::ELFDATA2LSB
} else {
    elf::ELFDATA2MSB
};

/// The ELF checks 2–5 of the module doc.
fn check_elf(data: &[u8]) -> Result<(), Problem> {
    let len = data.len() as u64;
    let header_size = size_of::<Header>() as u64;
    if len < header_size {
        return refuse(format!(
            "it is truncated: {len} bytes, shorter than an ELF header ({header_size} bytes)"
        ));
    }
    let (class, encoding, version) = (data[4], data[5], data[6]);
    if class != HOST_CLASS {
        return refuse(format!(
            "it is a {} library, and this host is {}-bit",
            class_name(class),
            usize::BITS
        ));
    }
    if encoding != HOST_DATA {
        return refuse(format!(
            "its byte order is {}, and this host is {}",
            data_name(encoding),
            data_name(HOST_DATA)
        ));
    }
    if version != elf::EV_CURRENT {
        return refuse(format!("its ELF version is {version}, not 1"));
    }
    let header = Header::parse(data).map_err(|e| Problem::Refused(format!("bad ELF header: {e}")))?;
    let endian = header
        .endian()
        .map_err(|e| Problem::Refused(format!("bad ELF header: {e}")))?;
    match header.e_type(endian) {
        elf::ET_DYN => {}
        elf::ET_REL => {
            return refuse("it is an object file (.o), not a shared library: link it with -shared".into());
        }
        elf::ET_EXEC => return refuse("it is an executable, not a shared library".into()),
        elf::ET_CORE => return refuse("it is a core dump, not a shared library".into()),
        t => return refuse(format!("its ELF type is {t}, not a shared library (ET_DYN)")),
    }
    let machine = header.e_machine(endian);
    if let Some(host) = host_machine()
        && machine != host
    {
        return refuse(format!(
            "it was built for {}, and this host is {}",
            machine_name(machine),
            machine_name(host)
        ));
    }
    check_extents(header, endian, data)?;
    check_entry(header, endian, data)
}

/// Check 4: headers, segments and sections within the file.
// An ELF word is u64 here but u32 on a 32-bit host: the `.into()`s are needed there.
#[allow(clippy::useless_conversion)]
fn check_extents(header: &Header, endian: object::Endianness, data: &[u8]) -> Result<(), Problem> {
    let len = data.len() as u64;
    let truncated = |what: String, end: u64| {
        Problem::Refused(format!(
            "it is truncated: {what} ends at byte {end}, but the file has {len} bytes (was it cut short while copying?)"
        ))
    };
    let phoff: u64 = header.e_phoff(endian).into();
    let phnum = u64::from(header.e_phnum(endian));
    let ph_end = phoff.saturating_add(phnum.saturating_mul(u64::from(header.e_phentsize(endian))));
    if ph_end > len {
        return Err(truncated(
            format!("its program header table ({phnum} entries)"),
            ph_end,
        ));
    }
    let segments = header
        .program_headers(endian, data)
        .map_err(|e| Problem::Refused(format!("bad program headers: {e}")))?;
    let mut dynamic = false;
    for (i, s) in segments.iter().enumerate() {
        let (offset, size) = s.file_range(endian);
        let end = offset.saturating_add(size);
        if end > len {
            return Err(truncated(
                format!("segment {i} ({})", segment_name(s.p_type(endian))),
                end,
            ));
        }
        dynamic |= s.p_type(endian) == elf::PT_DYNAMIC;
    }
    if !dynamic {
        return refuse("it has no dynamic segment (PT_DYNAMIC), so it is not a shared library".into());
    }
    let shoff: u64 = header.e_shoff(endian).into();
    if shoff != 0 {
        let shnum = u64::from(header.e_shnum(endian));
        let sh_end = shoff.saturating_add(shnum.saturating_mul(u64::from(header.e_shentsize(endian))));
        if sh_end > len {
            return Err(truncated(
                format!("its section header table ({shnum} entries)"),
                sh_end,
            ));
        }
    }
    let sections = header
        .sections(endian, data)
        .map_err(|e| Problem::Refused(format!("bad section headers: {e}")))?;
    for (i, s) in sections.iter().enumerate() {
        if let Some((offset, size)) = s.file_range(endian) {
            let end = offset.saturating_add(size);
            if end > len {
                let name = sections.section_name(endian, s).unwrap_or(b"?");
                return Err(truncated(
                    format!("section {i} ({})", String::from_utf8_lossy(name)),
                    end,
                ));
            }
        }
    }
    Ok(())
}

/// Check 5: the entry symbol is a function in an executable section.
// An ELF word is u64 here but u32 on a 32-bit host: the `.into()`s are needed there.
#[allow(clippy::useless_conversion)]
fn check_entry(header: &Header, endian: object::Endianness, data: &[u8]) -> Result<(), Problem> {
    let sections = header
        .sections(endian, data)
        .map_err(|e| Problem::Refused(format!("bad section headers: {e}")))?;
    if sections.is_empty() {
        // Stripped of section headers: the loader reads the symbol table through the dynamic segment;
        // see the module doc.
        return Ok(());
    }
    let symbols = sections
        .symbols(endian, data, elf::SHT_DYNSYM)
        .map_err(|e| Problem::Refused(format!("bad dynamic symbol table: {e}")))?;
    let entry = symbols.iter().find(|s| {
        !s.is_undefined(endian)
            && symbols
                .symbol_name(endian, s)
                .is_ok_and(|n| n == ENTRY_SYMBOL.as_bytes())
    });
    let Some(sym) = entry else {
        return Err(Problem::NoEntry(
            "the symbol is not defined in its dynamic symbol table".into(),
        ));
    };
    let what = format!("its entry point `{ENTRY_SYMBOL}`");
    match sym.st_type() {
        elf::STT_FUNC | elf::STT_GNU_IFUNC => {}
        elf::STT_OBJECT => {
            return refuse(format!("{what} is a data object (STT_OBJECT), not a function"));
        }
        t => {
            return refuse(format!(
                "{what} is of symbol type {}, not a function",
                symbol_type_name(t)
            ));
        }
    }
    let index = sym.st_shndx(endian);
    let value: u64 = sym.st_value(endian).into();
    if index == elf::SHN_ABS {
        return refuse(format!(
            "{what} is an absolute address ({value:#x}), not code in the library"
        ));
    }
    if index >= elf::SHN_LORESERVE {
        return refuse(format!("{what} is in no section (special index {index:#x})"));
    }
    let section = sections
        .section(object::SectionIndex(usize::from(index)))
        .map_err(|_| Problem::Refused(format!("{what} names section {index}, which does not exist")))?;
    let name = String::from_utf8_lossy(sections.section_name(endian, section).unwrap_or(b"?")).into_owned();
    let flags: u64 = section.sh_flags(endian).into();
    if flags & u64::from(elf::SHF_EXECINSTR) == 0 {
        return refuse(format!(
            "{what} lies in section {name}, which is not executable: it is not a function"
        ));
    }
    let start: u64 = section.sh_addr(endian).into();
    let size: u64 = section.sh_size(endian).into();
    if value < start || value >= start.saturating_add(size) {
        return refuse(format!(
            "{what} is at {value:#x}, outside its section {name} ({start:#x}..{:#x})",
            start.saturating_add(size)
        ));
    }
    Ok(())
}

/// The `e_machine` of the host, where we know it.
fn host_machine() -> Option<u16> {
    Some(match std::env::consts::ARCH {
        "x86_64" => elf::EM_X86_64,
        "x86" => elf::EM_386,
        "aarch64" => elf::EM_AARCH64,
        "arm" => elf::EM_ARM,
        "riscv64" | "riscv32" => elf::EM_RISCV,
        "powerpc64" => elf::EM_PPC64,
        "s390x" => elf::EM_S390,
        "loongarch64" => elf::EM_LOONGARCH,
        _ => return None,
    })
}

fn machine_name(m: u16) -> String {
    let name = match m {
        elf::EM_X86_64 => "x86-64",
        elf::EM_386 => "x86 (i386)",
        elf::EM_AARCH64 => "AArch64 (ARM 64-bit)",
        elf::EM_ARM => "ARM (32-bit)",
        elf::EM_RISCV => "RISC-V",
        elf::EM_PPC64 => "PowerPC 64",
        elf::EM_S390 => "IBM S/390",
        elf::EM_LOONGARCH => "LoongArch",
        _ => return format!("machine {m} (e_machine)"),
    };
    name.to_string()
}

fn class_name(c: u8) -> String {
    match c {
        elf::ELFCLASS32 => "32-bit".into(),
        elf::ELFCLASS64 => "64-bit".into(),
        c => format!("class-{c} (neither 32- nor 64-bit)"),
    }
}

fn data_name(d: u8) -> String {
    match d {
        elf::ELFDATA2LSB => "little-endian".into(),
        elf::ELFDATA2MSB => "big-endian".into(),
        d => format!("unknown (ELF data encoding {d})"),
    }
}

fn segment_name(t: u32) -> String {
    match t {
        elf::PT_LOAD => "PT_LOAD".into(),
        elf::PT_DYNAMIC => "PT_DYNAMIC".into(),
        elf::PT_INTERP => "PT_INTERP".into(),
        elf::PT_NOTE => "PT_NOTE".into(),
        t => format!("type {t:#x}"),
    }
}

fn symbol_type_name(t: u8) -> String {
    match t {
        elf::STT_NOTYPE => "STT_NOTYPE (untyped)".into(),
        elf::STT_SECTION => "STT_SECTION".into(),
        elf::STT_FILE => "STT_FILE".into(),
        elf::STT_COMMON => "STT_COMMON (data)".into(),
        elf::STT_TLS => "STT_TLS (thread-local data)".into(),
        t => t.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(data: &[u8]) -> String {
        match check_bytes(data) {
            Err(Problem::Refused(r)) => r,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn files_of_other_kinds_are_named() {
        assert!(refused(b"").contains("empty (0 bytes)"));
        assert!(refused(b"hello plugin\n").contains("a text file (it starts \"hello plugin\")"));
        assert!(refused(b"!<arch>\nfoo").contains("static library archive"));
        let mut macho = vec![0xcf, 0xfa, 0xed, 0xfe];
        macho.resize(64, 0);
        let mut pe = b"MZ".to_vec();
        pe.resize(64, 0);
        if Kind::HOST == Kind::Elf {
            assert!(refused(&macho).contains("a Mach-O file (macOS), and this host loads ELF"));
            assert!(refused(&pe).contains("a PE file"));
        }
        assert!(refused(&[0, 1, 2, 3, 0xff]).contains("starts with the bytes 00 01 02 03"));
    }

    #[cfg(all(target_pointer_width = "64", target_endian = "little"))]
    #[test]
    fn elf_identity_is_checked_before_anything_is_parsed() {
        let mut h = vec![0u8; 64];
        h[..4].copy_from_slice(&elf::ELFMAG);
        h[4] = elf::ELFCLASS64;
        h[5] = elf::ELFDATA2LSB;
        h[6] = elf::EV_CURRENT;
        assert!(refused(&h[..40]).contains("truncated: 40 bytes, shorter than an ELF header (64 bytes)"));
        let mut c = h.clone();
        c[4] = elf::ELFCLASS32;
        assert!(
            refused(&c).contains("a 32-bit library, and this host is 64-bit"),
            "{}",
            refused(&c)
        );
        let mut d = h.clone();
        d[5] = elf::ELFDATA2MSB;
        assert!(refused(&d).contains("big-endian, and this host is little-endian"));
        // e_type at 16: ET_REL.
        let mut r = h.clone();
        r[16] = 1;
        assert!(refused(&r).contains("object file (.o)"));
    }
}
