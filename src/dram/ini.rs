//! DRAMsim3 configuration files: the shipped ones (`configs/dram/`, built
//! into the binary), reading a user's, the geometry DRAMsim3 derives from
//! them, and the ini text handed to DRAMsim3 with this project's overrides.
//!
//! Rules:
//! 1. `dram_config` is a shipped name (with or without `.ini`), else a path
//!    (relative to the current directory).
//! 2. DRAMsim3 exits the process on a bad file, so every value it needs is
//!    checked here first; errors name the file and the key.
//! 3. The geometry follows DRAMsim3's `Config` (`configuration.cc`:
//!    `InitDRAMParams`, `CalculateSize`, `SetAddressMapping`) integer for
//!    integer, so that [`Geometry::decode`] maps an address to the bank and
//!    row DRAMsim3 uses.
//! 4. The text DRAMsim3 reads is the file without its `address_mapping`
//!    (when overridden), `epoch_period` and `output_level`, then
//!    `address_mapping` (the override or the file's), `epoch_period =
//!    2147483647` and `output_level = 0`: no epoch or statistics files
//!    (DRAMsim3's reader joins repeated keys, hence removal, not a second
//!    value).

use std::collections::BTreeMap;
use std::path::Path;

/// The DRAMsim3 configurations shipped in `configs/dram/`: (name, text).
pub const SHIPPED: &[(&str, &str)] = &[
    ("lpddr_2Gb_x16", include_str!("../../configs/dram/lpddr_2Gb_x16.ini")),
    ("DDR3_1Gb_x8_1333", include_str!("../../configs/dram/DDR3_1Gb_x8_1333.ini")),
    ("DDR4_8Gb_x8_3200", include_str!("../../configs/dram/DDR4_8Gb_x8_3200.ini")),
    ("LPDDR4_8Gb_x16_2400", include_str!("../../configs/dram/LPDDR4_8Gb_x16_2400.ini")),
    ("HBM2_8Gb_x128", include_str!("../../configs/dram/HBM2_8Gb_x128.ini")),
];

/// An ini file: `section → key → value`, as DRAMsim3's reader (inih)
/// sees it (keys lower-cased, `;` starts a comment anywhere, `#` at the
/// start of a line).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ini {
    /// Where it came from (a shipped name or a path), for messages.
    pub origin: String,
    /// The text as read.
    pub text: String,
    values: BTreeMap<(String, String), String>,
}

/// One ini line: a section header, a `key = value`, or nothing.
enum Line<'a> {
    Section(&'a str),
    Pair(&'a str, &'a str),
    Blank,
}

fn classify(raw: &str) -> Result<Line<'_>, String> {
    let line = raw.split(';').next().unwrap_or("").trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(Line::Blank);
    }
    if let Some(rest) = line.strip_prefix('[') {
        let name = rest.strip_suffix(']').ok_or_else(|| format!("`{line}`: expected `[section]`"))?;
        return Ok(Line::Section(name.trim()));
    }
    let (k, v) = line.split_once('=').ok_or_else(|| format!("`{line}`: expected `key = value`"))?;
    Ok(Line::Pair(k.trim(), v.trim()))
}

impl Ini {
    /// Parse `text` from `origin`; the error names the origin and line.
    pub fn parse(text: &str, origin: &str) -> Result<Ini, String> {
        let mut ini = Ini { origin: origin.to_string(), text: text.to_string(), values: BTreeMap::new() };
        let mut section = String::new();
        for (n, raw) in text.lines().enumerate() {
            match classify(raw).map_err(|e| format!("{origin}:{}: {e}", n + 1))? {
                Line::Section(s) => section = s.to_lowercase(),
                Line::Pair(k, v) => {
                    ini.values.insert((section.clone(), k.to_lowercase()), v.to_string());
                }
                Line::Blank => {}
            }
        }
        Ok(ini)
    }

    /// The shipped configuration `name`, or the file at path `name`.
    pub fn load(name: &str) -> Result<Ini, String> {
        let bare = name.strip_suffix(".ini").unwrap_or(name);
        if let Some((n, text)) = SHIPPED.iter().find(|(n, _)| *n == bare) {
            return Ini::parse(text, &format!("configs/dram/{n}.ini"));
        }
        let path = Path::new(name);
        if !path.is_file() {
            return Err(format!(
                "dram_config = \"{name}\": neither a shipped DRAMsim3 configuration ({}) nor a file",
                SHIPPED.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
            ));
        }
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("dram_config = \"{name}\": reading {name}: {e}"))?;
        Ini::parse(&text, name)
    }

    /// The value of `key` in `section`, if set.
    pub fn get(&self, section: &str, key: &str) -> Option<&str> {
        self.values.get(&(section.to_string(), key.to_string())).map(String::as_str)
    }

    /// An integer value, or `default` when absent; the error names the key.
    pub fn int(&self, section: &str, key: &str, default: i64) -> Result<i64, String> {
        match self.get(section, key) {
            None => Ok(default),
            Some(v) => v.parse().map_err(|_| format!("{}: [{section}] {key} = {v}: expected an integer", self.origin)),
        }
    }

    /// A real value, or `default` when absent.
    pub fn real(&self, section: &str, key: &str, default: f64) -> Result<f64, String> {
        match self.get(section, key) {
            None => Ok(default),
            Some(v) => v
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{}: [{section}] {key} = {v}: expected a number", self.origin)),
        }
    }

    /// The text DRAMsim3 reads (module rule 4), with `mapping` for
    /// `address_mapping`.
    pub fn for_dramsim3(&self, mapping: &str) -> String {
        let mut out = String::new();
        let mut section = String::new();
        for raw in self.text.lines() {
            let drop = match classify(raw) {
                Ok(Line::Section(s)) => {
                    section = s.to_lowercase();
                    false
                }
                Ok(Line::Pair(k, _)) => {
                    let k = k.to_lowercase();
                    (section == "system" && k == "address_mapping")
                        || (section == "other" && (k == "epoch_period" || k == "output_level"))
                }
                _ => false,
            };
            if !drop {
                out.push_str(raw);
                out.push('\n');
            }
        }
        out.push_str(&format!(
            "\n; added by postwarp (src/dram/ini.rs)\n[system]\naddress_mapping = {mapping}\n\n[other]\nepoch_period = \
             2147483647\noutput_level = 0\n"
        ));
        out
    }
}

/// What DRAMsim3 derives from a configuration (module rule 3).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Geometry {
    /// The `protocol` name.
    pub protocol: String,
    /// DRAM clock period, rounded to picoseconds (ps).
    pub tck_ps: u64,
    /// Bytes of one DRAMsim3 transaction: `bus_width / 8 × BL` (bytes).
    pub transaction_bytes: u64,
    /// Bytes one channel's data bus moves per DRAM cycle (bytes).
    pub bus_bytes_per_cycle: u64,
    /// Channels.
    pub channels: u64,
    /// The address mapping in force.
    pub mapping: String,
    /// Low address bits below the mapped fields (`log2(transaction_bytes)`).
    shift_bits: u32,
    /// (position, mask) of ch, ra, bg, ba, ro (bits above `shift_bits`).
    fields: [(u32, u64); 5],
    /// Field widths of ch, ra, bg, ba, ro, co (bits).
    widths: [u32; 6],
}

/// DRAMsim3's `LogBase2`: floor of log2 (0 for 0 and 1).
fn log2(n: i64) -> u32 {
    if n <= 1 { 0 } else { 63 - (n as u64).leading_zeros() }
}

/// A DRAM location: channel, rank, bank group, bank, row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Location {
    /// The bank: channel, rank, bank group and bank packed.
    pub bank: u64,
    /// The row in that bank.
    pub row: u64,
}

impl Geometry {
    /// The geometry of `ini` with `mapping` (empty: the ini's, DRAMsim3's
    /// default `chrobabgraco` if it has none).
    pub fn of(ini: &Ini, mapping: &str) -> Result<Geometry, String> {
        let o = &ini.origin;
        let protocol = ini.get("dram_structure", "protocol").unwrap_or("DDR3").to_string();
        let known = ["DDR3", "DDR4", "GDDR5", "GDDR5X", "GDDR6", "LPDDR", "LPDDR3", "LPDDR4", "HBM", "HBM2"];
        if !known.contains(&protocol.as_str()) {
            return Err(format!(
                "{o}: [dram_structure] protocol = {protocol}: expected one of {} (HMC is not supported)",
                known.join(", ")
            ));
        }
        let positive = |section: &str, key: &str, default: i64| -> Result<i64, String> {
            let v = ini.int(section, key, default)?;
            if v > 0 && v < 1 << 30 {
                Ok(v)
            } else {
                Err(format!("{o}: [{section}] {key} = {v}: expected a positive integer"))
            }
        };
        let mut bankgroups = positive("dram_structure", "bankgroups", 2)?;
        let mut banks_per_group = positive("dram_structure", "banks_per_group", 2)?;
        if ini.get("dram_structure", "bankgroup_enable").is_some_and(|v| matches!(v, "false" | "0" | "off" | "no")) {
            banks_per_group *= bankgroups;
            bankgroups = 1;
        }
        let banks = bankgroups * banks_per_group;
        let rows = positive("dram_structure", "rows", 1 << 16)?;
        let mut columns = positive("dram_structure", "columns", 1 << 10)?;
        let device_width = positive("dram_structure", "device_width", 8)?;
        let bl = positive("dram_structure", "bl", 8)?;
        let burst_cycle = match protocol.as_str() {
            "GDDR5" => bl / 4,
            "GDDR5X" => bl / 8,
            "GDDR6" => bl / 16,
            _ => bl / 2,
        };
        if burst_cycle == 0 {
            return Err(format!("{o}: [dram_structure] BL = {bl}: too short a burst for {protocol}"));
        }
        if protocol.starts_with("GDDR") {
            columns *= bl;
        } else if protocol.starts_with("HBM") {
            columns *= 2;
        }
        let channel_size = positive("system", "channel_size", 1024)?;
        let channels = positive("system", "channels", 1)?;
        let bus_width = positive("system", "bus_width", 64)?;
        if bus_width % device_width != 0 || bus_width % 8 != 0 {
            return Err(format!(
                "{o}: [system] bus_width = {bus_width}: expected a multiple of 8 and of device_width ({device_width})"
            ));
        }
        let devices_per_rank = bus_width / device_width;
        let page_size = columns * device_width / 8;
        let megs_per_bank = page_size * (rows / 1024) / 1024;
        let megs_per_rank = megs_per_bank * banks * devices_per_rank;
        let ranks = if megs_per_rank > channel_size || megs_per_rank == 0 { 1 } else { channel_size / megs_per_rank };
        let tck = ini.real("timing", "tck", 1.0)?;
        if !(0.05..=1000.0).contains(&tck) {
            return Err(format!("{o}: [timing] tCK = {tck}: expected 0.05 to 1000 ns"));
        }
        let mapping = if mapping.is_empty() {
            ini.get("system", "address_mapping").unwrap_or("chrobabgraco").to_string()
        } else {
            mapping.to_string()
        };
        postwarp_rtl::config::check_address_mapping(&mapping).map_err(|e| format!("{o}: {e}"))?;
        let transaction_bytes = (bus_width / 8 * bl) as u64;
        let widths = [
            log2(channels),
            log2(ranks),
            log2(bankgroups),
            log2(banks_per_group),
            log2(rows),
            log2(columns).saturating_sub(log2(bl)),
        ];
        let names = ["ch", "ra", "bg", "ba", "ro", "co"];
        // From the last (least significant) field up, as DRAMsim3 does.
        let mut pos = [0u32; 6];
        let mut at = 0;
        for i in (0..6).rev() {
            let token = &mapping[2 * i..2 * i + 2];
            let f = names.iter().position(|n| *n == token).expect("checked mapping");
            pos[f] = at;
            at += widths[f];
        }
        let mask = |w: u32| (1u64 << w) - 1;
        Ok(Geometry {
            protocol,
            tck_ps: (tck * 1000.0).round() as u64,
            transaction_bytes,
            bus_bytes_per_cycle: (bus_width / 8 * bl / burst_cycle) as u64,
            channels: channels as u64,
            mapping,
            shift_bits: log2(transaction_bytes as i64),
            fields: [0, 1, 2, 3, 4].map(|f| (pos[f], mask(widths[f]))),
            widths,
        })
    }

    /// The bank and row DRAMsim3 maps byte address `addr` to.
    pub fn decode(&self, addr: u64) -> Location {
        let a = addr >> self.shift_bits;
        let f = |i: usize| (a >> self.fields[i].0) & self.fields[i].1;
        let [wch, wra, wbg, wba, _, _] = self.widths;
        let bank = (((f(0) << wra | f(1)) << wbg | f(2)) << wba) | f(3);
        debug_assert!(bank < 1 << (wch + wra + wbg + wba));
        Location { bank, row: f(4) }
    }

    /// DRAM cycles per engine cycle as a fraction `(num, den)` of engine
    /// clock `clock_hz`: `1e12 / (clock_hz × tck_ps)` without rounding.
    pub fn clock_ratio(&self, clock_hz: u64) -> (u128, u128) {
        (1_000_000_000_000, clock_hz as u128 * self.tck_ps as u128)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ddr4() -> Ini {
        Ini::load("DDR4_8Gb_x8_3200").unwrap()
    }

    #[test]
    fn every_shipped_configuration_parses_with_its_geometry() {
        for (name, _) in SHIPPED {
            let ini = Ini::load(name).unwrap();
            let g = Geometry::of(&ini, "").unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(g.transaction_bytes >= 32 && g.transaction_bytes.is_power_of_two(), "{name}: {g:?}");
            assert_eq!(Ini::load(&format!("{name}.ini")).unwrap(), ini);
        }
    }

    #[test]
    fn ddr4_3200_is_mapped_as_dramsim3_maps_it() {
        let g = Geometry::of(&ddr4(), "").unwrap();
        // 64-bit bus, BL8: 64-byte transactions; 2 beats per tCK.
        assert_eq!((g.transaction_bytes, g.bus_bytes_per_cycle, g.tck_ps, g.channels), (64, 16, 630, 1));
        // x8 devices: 8 per rank; page 1 KiB; 16384 MB / 8192 MB per rank = 2 ranks.
        // ch 0, ra 1, bg 2, ba 2, ro 16, co 10 - 3 = 7 bits.
        assert_eq!(g.widths, [0, 1, 2, 2, 16, 7]);
        assert_eq!(g.mapping, "rochrababgco");
        // rochrababgco: co bits 0-6, bg 7-8, ba 9-10, ra 11, ch -, ro 12-27 (above the 6 shift bits).
        let at = |bg: u64, ba: u64, ra: u64, ro: u64, co: u64| (ro << 12 | ra << 11 | ba << 9 | bg << 7 | co) << 6;
        assert_eq!(g.decode(at(0, 0, 0, 0, 5)), g.decode(0), "same row, another column");
        let l = g.decode(at(3, 1, 1, 777, 0));
        assert_eq!((l.bank, l.row), ((1 << 4) | (3 << 2) | 1, 777));
        // Another mapping moves the row bits down.
        let h = Geometry::of(&ddr4(), "chrobabgraco").unwrap();
        assert_eq!(h.decode(1 << (6 + 7 + 1 + 2 + 2)).row, 1);
    }

    #[test]
    fn the_clock_ratio_is_exact() {
        let g = Geometry::of(&ddr4(), "").unwrap();
        // 100 MHz engine, 0.63 ns DRAM clock: 10 ns / 0.63 ns.
        assert_eq!(g.clock_ratio(100_000_000), (1_000_000_000_000, 63_000_000_000));
    }

    #[test]
    fn the_text_for_dramsim3_overrides_and_silences_once() {
        let t = ddr4().for_dramsim3("robabgrachco");
        let back = Ini::parse(&t, "x").unwrap();
        assert_eq!(back.get("system", "address_mapping"), Some("robabgrachco"));
        assert_eq!(back.get("other", "output_level"), Some("0"));
        assert_eq!(t.matches("address_mapping").count(), 1, "{t}");
        assert_eq!(t.matches("epoch_period").count(), 1);
        assert_eq!(back.get("timing", "tck"), Some("0.63"));
    }

    #[test]
    fn bad_configurations_are_named() {
        let e = Ini::load("DDR9_nope").unwrap_err();
        assert!(e.contains("DDR4_8Gb_x8_3200") && e.contains("DDR9_nope"), "{e}");
        let e = Ini::parse("[timing]\ntCK 1\n", "f.ini").unwrap_err();
        assert!(e.starts_with("f.ini:2: "), "{e}");
        let bad = Ini::parse("[dram_structure]\nprotocol = HMC\n", "h.ini").unwrap();
        assert!(Geometry::of(&bad, "").unwrap_err().contains("HMC"));
        let bad = Ini::parse("[dram_structure]\nrows = -4\n", "r.ini").unwrap();
        assert!(Geometry::of(&bad, "").unwrap_err().contains("rows = -4"));
        assert!(Geometry::of(&ddr4(), "rorororororo").unwrap_err().contains("dram_address_mapping"));
    }
}
