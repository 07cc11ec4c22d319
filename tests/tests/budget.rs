//! The load balancer's promise, end to end: the rays each frame's work list traces never exceed
//! that frame's budget, on every frame of the built-in room's animated sequence (its motion, its
//! lights and its camera cut) for each signal, through full VRRT at 1 ray per pixel.
//!
//! Why end to end: the balancer fits the *expected* rays to the budget, and apply realises the
//! fractional rates with blue-noise coin flips; the trim ([`vrrt_core::kernels::trim`]) is what
//! bounds the realised rays, and its unit test covers random rates. Here the rays are counted
//! from the frame's own requests and decisions, as apply made them.
//!
//! What this does not cover: the change detector's refill lists, traced after the main list and
//! paid from the next frame's budget (`vrrt_core::kernels::refill`).

use vrrt_cli::backend::{Backend, BackendKind};
use vrrt_cli::session::Config;
use vrrt_core::kernels::{balance, trim};
use vrrt_core::reflections::ReflectionSettings;
use vrrt_core::settings::Settings;
use vrrt_scene::render::{Readback, Renderer, Signal};

const SIZE: (u32, u32) = (96, 54);
/// The room's camera cut is at frame 60.
const FRAMES: u32 = 72;

#[test]
fn no_frame_traces_more_than_its_budget() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let signals = [
        ("ao", Signal::Ao { max_distance: 1.0 }),
        ("shadows", Signal::Shadows),
        (
            "reflections",
            Signal::Reflections(ReflectionSettings::default()),
        ),
    ];
    let mut trimmed = 0;
    for (name, signal) in signals {
        let mut exec = Backend::open(BackendKind::Cpu, false).unwrap().0;
        let settings = Config::Vrrt.settings(Settings::default(), 1.0, signal);
        let (w, h) = SIZE;
        let mut r = Renderer::new(&mut exec, w, h, signal, scene.lights.len(), settings).unwrap();
        for i in 0..FRAMES {
            let out = r
                .render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap();
            assert_eq!(out.decisions.len(), 1, "{name}: one plane group");
            let d: &balance::Balance = &out.decisions[0];
            let realised: f64 = out.rays.iter().map(|&r| r as f64).sum();
            assert_eq!(
                realised.round() as u32,
                d.traced,
                "{name}, frame {i}: the trim's count is what apply realised"
            );
            assert!(
                d.cut < trim::BINS && d.traced as f32 <= d.budget.floor(),
                "{name}, frame {i}: {} rays against a budget of {} (cut {})",
                d.traced,
                d.budget,
                d.cut
            );
            trimmed += (d.cut > 0) as u32;
        }
    }
    // The coin flips land over the budget on a good share of the frames: the trim was tested.
    assert!(trimmed > 10, "only {trimmed} frames trimmed");
}
