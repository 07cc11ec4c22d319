//! Configuration, signal, backend and scene names: the value parsers accept exactly the
//! documented names, and clap agrees with them on `--denoiser`, `--configs`, `--signal`,
//! `--signals`, `--backend` and `--backends` (the first byte picks the flag).
#![no_main]
use clap::ValueEnum;
use vrrt_cli::session::{parse_backend, Config, SignalKind};
use vrrt_fuzz::{check_one_line, clap_parse, Command};

const FORMS: [&[&str]; 6] = [
    &["run", "--denoiser"],
    &["bench", "--configs"],
    &["run", "--signal"],
    &["bench", "--signals"],
    &["run", "--backend"],
    &["bench", "--backends"],
];

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&form, value)) = data.split_first() else {
        return;
    };
    let s = String::from_utf8_lossy(value).into_owned();
    let config = Config::from_str(&s, false);
    if let Ok(c) = config {
        assert_eq!(c.name(), s);
    }
    let signal = SignalKind::from_str(&s, false);
    if let Ok(k) = signal {
        assert_eq!(k.name(), s);
    }
    let backend = parse_backend(&s);
    match &backend {
        Ok(_) => assert!(["auto", "cpu", "wgpu", "ash"].contains(&s.as_str()), "{s}"),
        Err(e) => check_one_line(e, &s),
    }
    if s.len() <= 16 {
        match vrrt_scene::builtin::builtin(&s) {
            Ok(_) => assert!(["room", "room_static"].contains(&s.as_str()), "{s}"),
            Err(e) => check_one_line(&e.to_string(), &s),
        }
    }
    let form = FORMS[form as usize % FORMS.len()];
    let Some(cli) = clap_parse(form, value) else {
        return;
    };
    let items: Vec<&str> = s.split(',').collect();
    let agrees = match &cli.command {
        Command::Run(a) if form[1] == "--denoiser" => config == Ok(a.denoiser),
        Command::Run(a) if form[1] == "--signal" => signal == Ok(a.signal),
        Command::Run(a) => backend == Ok(a.backend),
        Command::Bench(a) if form[1] == "--configs" => items
            .iter()
            .map(|s| Config::from_str(s, false))
            .eq(a.configs.iter().map(|c| Ok(*c))),
        Command::Bench(a) if form[1] == "--signals" => items
            .iter()
            .map(|s| SignalKind::from_str(s, false))
            .eq(a.signals.iter().map(|k| Ok(*k))),
        Command::Bench(a) => items
            .iter()
            .map(|s| parse_backend(s))
            .eq(a.backends.iter().map(|b| Ok(*b))),
        _ => false,
    };
    assert!(agrees, "clap reads {form:?} {s:?} differently");
});
