//! DRAM backends of the hardware model that need this crate (files, a C++
//! simulator): `dram_backend = "dramsim3"` behind the cycle model's
//! channel (`postwarp_rtl::mem::backend`), and the engine for a
//! configuration with its backend.
//!
//! Files: `ini.rs` (the shipped DRAMsim3 configurations, reading and
//! checking one, the geometry and address mapping DRAMsim3 derives, the
//! text it is given), `rows.rs` (row-buffer hits counted from the
//! addresses), `dramsim3_backend.rs` (the closed loop; cargo feature
//! `dramsim3`).
//!
//! Rules: `ideal` needs nothing from here; `dramsim3` in a build without
//! the feature is an error saying how to rebuild. `docs/memory.md`.

pub mod ini;
pub mod rows;

#[cfg(feature = "dramsim3")]
pub mod dramsim3_backend;

use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::Engine;

/// Whether this build has the DRAMsim3 backend (cargo feature `dramsim3`).
pub const HAS_DRAMSIM3: bool = cfg!(feature = "dramsim3");

/// The error of `dram_backend = "dramsim3"` in a build without it.
pub const NO_DRAMSIM3: &str = "dram_backend = \"dramsim3\": this postwarp was built without the DRAMsim3 backend; \
                               rebuild with `--features dramsim3` (e.g. `cargo run --release --features dramsim3 -- \
                               simulate ...`; needs cmake)";

/// Check `cfg`'s DRAM backend knobs against this build and the DRAMsim3
/// configuration they name (the message names the knob or the file).
pub fn check(cfg: &EngineConfig) -> Result<(), String> {
    match cfg.dram_backend.as_str() {
        "dramsim3" if !HAS_DRAMSIM3 => Err(NO_DRAMSIM3.into()),
        "dramsim3" => {
            let ini = ini::Ini::load(&cfg.dram_config)?;
            ini::Geometry::of(&ini, &cfg.dram_address_mapping).map(|_| ())
        }
        _ => Ok(()),
    }
}

/// The engine for `cfg`, its DRAM timed by the backend `dram_backend` names.
pub fn engine(cfg: EngineConfig) -> Result<Engine, String> {
    check(&cfg)?;
    match cfg.dram_backend.as_str() {
        #[cfg(feature = "dramsim3")]
        "dramsim3" => {
            let ini = ini::Ini::load(&cfg.dram_config)?;
            let f = dramsim3_backend::factory(&ini, &cfg.dram_address_mapping, cfg.clock_hz)?;
            Engine::with_dram_backend(cfg, f)
        }
        _ => Engine::new(cfg),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_backend_is_checked_against_the_build() {
        let mut c = EngineConfig::default();
        assert_eq!(check(&c), Ok(()));
        c.dram_backend = "dramsim3".into();
        if HAS_DRAMSIM3 {
            assert_eq!(check(&c), Ok(()));
            c.dram_config = "nope".into();
            assert!(check(&c).unwrap_err().contains("dram_config = \"nope\""));
        } else {
            assert!(check(&c).unwrap_err().contains("--features dramsim3"));
            assert!(engine(c).is_err());
        }
    }
}
