//! Orchestration: trace → frame commands → engines → images, metrics and
//! report files. One file per engine run.

pub mod golden;
