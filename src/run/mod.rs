//! Orchestration: trace → frame commands → engines → images, metrics and
//! report files. One file per engine run.

pub mod compare;
pub mod frame_exr;
pub mod golden;
pub mod hw_config;
pub mod hw_config_toml;
pub mod method;
pub mod score;
pub mod simulate;
pub mod timing;
