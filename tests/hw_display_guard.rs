//! The progress guard of the engine's last clock loop, the display read
//! (`rtl-model/src/watchdog.rs`): a DRAM backend that stops answering
//! while the display reads the frame stops the run with the guard's
//! internal error, naming the display as waiting for DRAM, instead of
//! hanging. The same backend that keeps answering gives the ideal
//! backend's frame and cycles, so the test's backend is not the cause.

use crate::common::{Layer, at_x, render};
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, HwReference};
use postwarp_rtl::mem::{Access, Client, DramBackend, DramConfig, IdealBackend, NextEvent};
use postwarp_rtl::{FrameCommands, SampleImage};
use std::sync::Arc;

const SS: u32 = 2;

/// The ideal backend, deaf from cycle `from` on: requests accepted then
/// never complete.
struct DeafFrom {
    inner: IdealBackend,
    from: Cycle,
    unanswered: u64,
}

impl DramBackend for DeafFrom {
    fn name(&self) -> &'static str {
        "deaf-from"
    }

    fn tick(&mut self, now: Cycle) {
        self.inner.tick(now);
    }

    fn skip_to(&mut self, now: Cycle) {
        self.inner.skip_to(now);
    }

    fn accept(&mut self, now: Cycle, id: u64, access: Access, addr: u64, bytes: u64) -> Option<Cycle> {
        if now >= self.from {
            self.unanswered += 1;
            return None;
        }
        self.inner.accept(now, id, access, addr, bytes)
    }

    fn pop_done(&mut self, now: Cycle) -> Option<(u64, Cycle)> {
        self.inner.pop_done(now)
    }

    fn next_event(&self) -> NextEvent {
        if self.unanswered > 0 { NextEvent::EveryCycle } else { self.inner.next_event() }
    }
}

fn scene() -> (SampleImage, FrameCommands) {
    let grey = |_: f64| [0.5, 0.5, 0.5];
    let layers = [Layer { z: 6.0, x0: -100.0, x1: 100.0, colour: grey }];
    let reference = at_x(24, 16, 0.0);
    let img = render(&reference, SS, &layers);
    let cmd = FrameCommands::new(0, at_x(24, 16, 0.05), SS, &[(0, reference)]);
    (img, cmd)
}

fn run(engine: &mut Engine, img: &SampleImage, cmd: &FrameCommands, cfg: &EngineConfig) -> FrameOutput {
    engine.run_frame(cmd, &[&HwReference::new(img, cfg)])
}

fn deaf_from(cfg: &EngineConfig, from: Cycle) -> Engine {
    let dram: DramConfig = cfg.dram();
    let make =
        move || Box::new(DeafFrom { inner: IdealBackend::new(dram), from, unanswered: 0 }) as Box<dyn DramBackend>;
    Engine::with_dram_backend(cfg.clone(), Arc::new(make)).unwrap()
}

#[test]
fn a_memory_that_stops_answering_during_the_display_read_is_reported_not_waited_for() {
    let (img, cmd) = scene();
    let cfg = EngineConfig { supersample: SS, ..EngineConfig::default() };
    let mut ideal = Engine::new(cfg.clone()).unwrap();
    ideal.record_requests(true);
    let want = run(&mut ideal, &img, &cmd, &cfg);
    let display: Vec<_> = want.requests.iter().filter(|r| r.client == Client::Output).collect();
    assert!(!display.is_empty(), "the display reads the frame");
    let first = display.iter().map(|r| r.accepted).min().unwrap();
    // Every request of the warps was accepted before the display's first.
    assert!(want.requests.iter().filter(|r| r.client != Client::Output).all(|r| r.accepted < first));

    // Deaf only after the frame: the same frame and cycles.
    let got = run(&mut deaf_from(&cfg, Cycle(u64::MAX)), &img, &cmd, &cfg);
    assert_eq!(got.stats.cycles, want.stats.cycles);
    assert_eq!(got.pixels, want.pixels);

    // Deaf from the display's first read: the guard stops the run (in
    // well under a second). On a thread, so that a run that waits for ever
    // fails this test after a minute instead of hanging the suite.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(move || run(&mut deaf_from(&cfg, first), &img, &cmd, &cfg).stats.cycles);
        tx.send(r.map_err(|p| p.downcast::<String>().map(|m| *m).unwrap_or_default())).ok();
    });
    let r = rx.recv_timeout(std::time::Duration::from_secs(60)).expect("the display read waited for ever");
    let msg = r.expect_err("the display read never ends, yet the run finished");
    assert!(msg.contains("internal error in the cycle model: no unit made progress"), "{msg}");
    assert!(msg.contains("display Stall(Dram)"), "{msg}");
}
