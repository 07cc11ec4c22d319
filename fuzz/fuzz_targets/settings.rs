//! Settings files (`--settings FILE`, TOML) through `vrrt_cli::settings::parse`: an accepted file
//! reads back through `to_toml` unchanged and every configuration's settings built on it are
//! valid; a refused one gives one line.
#![no_main]
use clap::ValueEnum;
use vrrt_cli::session::{Config, SignalKind};
use vrrt_cli::settings;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match settings::parse(&text) {
        Ok(s) => {
            assert_eq!(settings::parse(&settings::to_toml(&s)), Ok(s));
            for config in Config::ALL {
                for signal in SignalKind::value_variants() {
                    let c = config.settings(s, s.rates.rays_per_pixel, signal.signal(1.0));
                    if let Err(e) = c.validate() {
                        panic!(
                            "{} {} gives invalid settings: {e}",
                            config.name(),
                            signal.name()
                        );
                    }
                }
            }
        }
        Err(e) => vrrt_fuzz::check_one_line(&e, ""),
    }
});
