//! The load balancer's promise, end to end: no frame traces more rays than its budget, on every
//! frame of the built-in room's animated sequence (its motion, its lights and its camera cut)
//! for each signal and all of them at once, through full VRRT at 1 ray per pixel.
//!
//! Why end to end: the balancer fits the *expected* rays to the budget, apply realises the
//! fractional rates with blue-noise coin flips (bounded by [`vrrt_core::kernels::trim`]), and the
//! change detector's refill lists, made after the main pass, must fit what it left
//! ([`vrrt_core::kernels::refill::fit`]). Their unit tests cover random rates and lists; here
//! the rays are counted from the frames themselves.

use vrrt_backend::{Backend, BackendKind};
use vrrt_cli::session::Config;
use vrrt_core::kernels::{balance, trim};
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
        ("reflections", Signal::Reflections),
        ("all", Signal::All { max_distance: 1.0 }),
    ];
    let (mut trimmed, mut refilled) = (0, 0);
    for (name, signal) in signals {
        let mut exec = Backend::open(BackendKind::Cpu, false).unwrap().0;
        let settings = Config::Vrrt.settings(Settings::default(), 1.0, signal);
        let (w, h) = SIZE;
        let mut r = Renderer::new(&mut exec, w, h, signal, scene.lights.len(), settings).unwrap();
        for i in 0..FRAMES {
            let out = r
                .render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap();
            for (g, d) in out.decisions.iter().enumerate() {
                let d: &balance::Balance = d;
                // The main pass within the budget it was fitted to, the refill lists within
                // what it left.
                assert!(
                    d.cut < trim::BINS && d.traced as f32 <= d.budget.floor(),
                    "{name}, frame {i}, group {g}: {} rays against {} (cut {})",
                    d.traced,
                    d.budget,
                    d.cut
                );
                assert!(
                    d.traced + d.refill_traced <= d.allowed,
                    "{name}, frame {i}, group {g}: {} + {} rays against {}",
                    d.traced,
                    d.refill_traced,
                    d.allowed
                );
                trimmed += (d.cut > 0) as u32;
                refilled += (d.refill_traced > 0) as u32;
            }
            // Several groups' rays are counted per plane of the frame (a shadow ray of one of
            // three lights is a third of an AO ray), the budget alike: no rounding between them.
            assert!(
                out.rays_traced as f64 <= out.budget,
                "{name}, frame {i}: {} rays traced against a budget of {}",
                out.rays_traced,
                out.budget
            );
            if out.decisions.len() == 1 {
                // One group: the rays counted from the frame's requests are the trim's.
                let realised: f64 = out.rays.iter().map(|&r| r as f64).sum();
                assert_eq!(realised.round() as u32, out.decisions[0].traced);
            }
        }
    }
    // The coin flips land over the budget on a good share of the frames, and the detector
    // lists pixels: both bounds were exercised.
    assert!(trimmed > 10, "only {trimmed} frames trimmed");
    assert!(refilled > 10, "only {refilled} frames with refill lists");
}

/// Shadows alone shift their requests like AO (rays where history is shortest: after the cut,
/// a moving object whose shading the light changes loses its history every frame and gets the
/// rays), while in the shared frame their group keeps the seed's cap
/// (`docs/algorithms/balancer.md`).
#[test]
fn the_shadows_shift_their_requests_only_alone() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let modes = |signal: Signal| {
        let mut exec = Backend::open(BackendKind::Cpu, false).unwrap().0;
        let settings = Config::Vrrt.settings(Settings::default(), 1.0, signal);
        let (w, h) = SIZE;
        let mut r = Renderer::new(&mut exec, w, h, signal, scene.lights.len(), settings).unwrap();
        let layout = signal.layout(scene.lights.len());
        let (z, _) = layout.shadows.unwrap();
        let group = vrrt_core::kernels::plane_group(layout.plane_groups(), z) as usize;
        let mut modes = Vec::new();
        // The frames after the cut at 60: every pixel asks for a refill, over the budget. Not
        // frame 61, which sets aside a ray for each pixel the cut's penumbra lists held
        // (`balance::refill_reserve`): at this size that leaves its main pass under the shift's
        // floor, and the seed's cap decides.
        for i in 0..67 {
            let out = r
                .render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap();
            if i > 61 {
                modes.push(out.decisions[group].mode);
            }
        }
        modes
    };
    let (alone, shared) = (
        modes(Signal::Shadows),
        modes(Signal::All { max_distance: 1.0 }),
    );
    assert_eq!(alone, [balance::MODE_SHIFT; 5]);
    assert_eq!(shared, [balance::MODE_OVER; 5]);
}
