//! Size and rate arguments: `--size WxH`, the `--max-*` limits (bytes with a K/M/G/T suffix, or
//! counts) and ray budgets (`--rpp`, `--budgets`). The value parsers keep their ranges, and clap
//! reads a flag's value as its value parser does (the first byte picks the flag).
#![no_main]
use vrrt_cli::limits::{parse_bytes, parse_count};
use vrrt_cli::session::{parse_rpp, parse_size, MAX_DIMENSION};
use vrrt_fuzz::{check_one_line, clap_parse, Command};

const FORMS: [&[&str]; 11] = [
    &["run", "--size"],
    &["info", "--size"],
    &["bench", "--size"],
    &["reference", "--size"],
    &["run", "--max-file-size"],
    &["bench", "--max-decompressed"],
    &["reference", "--max-bvh-memory"],
    &["run", "--max-vertices"],
    &["bench", "--max-triangles"],
    &["run", "--rpp"],
    &["bench", "--budgets"],
];

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&form, value)) = data.split_first() else {
        return;
    };
    let s = String::from_utf8_lossy(value).into_owned();
    // Every value parser on every input.
    let size = parse_size(&s);
    match &size {
        Ok((w, h)) => {
            assert!((1..=MAX_DIMENSION).contains(w) && (1..=MAX_DIMENSION).contains(h));
            assert_eq!(parse_size(&format!("{w}x{h}")), Ok((*w, *h)));
        }
        Err(e) => check_one_line(e, &s),
    }
    for r in [parse_bytes(&s), parse_count(&s)] {
        match r {
            Ok(n) => assert!(n >= 1, "{s:?} parses as 0"),
            Err(e) => check_one_line(&e, &s),
        }
    }
    let rates: Vec<Result<f32, String>> = s.split(',').map(parse_rpp).collect();
    for r in rates.iter().chain([&parse_rpp(&s)]) {
        match r {
            Ok(v) => assert!(
                v.is_finite() && *v > 0.0 && *v <= 16.0,
                "{s:?} parses as {v}"
            ),
            Err(e) => check_one_line(e, &s),
        }
    }
    // Clap reads the flag as its value parser does.
    let form = FORMS[form as usize % FORMS.len()];
    let Some(cli) = clap_parse(form, value) else {
        return;
    };
    let (flag, limits) = (form[1], |l: &vrrt_cli::limits::LimitArgs| l.limits());
    match (&cli.command, flag) {
        (Command::Run(a), "--size") => assert_eq!(Ok(a.size), size),
        (Command::Info(a), "--size") => assert_eq!(Ok(a.size), size),
        (Command::Reference(a), "--size") => assert_eq!(Ok(a.size), size),
        (Command::Bench(a), "--size") => assert_eq!(a.size.ok_or(String::new()), size),
        (Command::Run(a), "--rpp") => assert_eq!(a.rpp.ok_or(String::new()), parse_rpp(&s)),
        (Command::Bench(a), "--budgets") => {
            let expect: Result<Vec<f32>, String> = rates.into_iter().collect();
            assert_eq!(Ok(a.budgets.clone()), expect);
        }
        (Command::Run(a), "--max-file-size") => {
            assert_eq!(Ok(limits(&a.limits).max_file_size), parse_bytes(&s))
        }
        (Command::Bench(a), "--max-decompressed") => {
            assert_eq!(Ok(limits(&a.limits).max_decompressed_size), parse_bytes(&s))
        }
        (Command::Reference(a), "--max-bvh-memory") => {
            assert_eq!(Ok(limits(&a.limits).max_bvh_bytes), parse_bytes(&s))
        }
        (Command::Run(a), "--max-vertices") => {
            assert_eq!(Ok(limits(&a.limits).max_vertices), parse_count(&s))
        }
        (Command::Bench(a), "--max-triangles") => {
            assert_eq!(Ok(limits(&a.limits).max_triangles), parse_count(&s))
        }
        _ => panic!("{form:?} parsed as another subcommand"),
    }
});
