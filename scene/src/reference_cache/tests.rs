//! Unit tests of the cache: round trips, damage, foreign keys, paths.

use super::entry::KEY_ATTRIBUTE;
use super::*;
use crate::image;

fn key() -> ReferenceKey {
    ReferenceKey {
        scene: "cornell box".into(),
        content: SceneHash([7; 32]),
        frame: 3,
        width: 5,
        height: 4,
        spp: 65536,
        signal: "ao-r0.5".into(),
        version: 1,
        estimator: ESTIMATOR_VERSION,
    }
}

fn test_image(channels: usize) -> Image {
    let data = (0..5 * 4 * channels)
        .map(|i| (i as f32 * 0.37).sin().abs() + 1e-7 * i as f32)
        .collect();
    Image::new(5, 4, channels, data).unwrap()
}

fn bits(data: &[f32]) -> Vec<u32> {
    data.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn paths_are_sanitised_and_distinct() {
    let k = key();
    assert_eq!(
        k.relative_path(),
        PathBuf::from(format!(
            "cornell_box/ao-r0.5/f000003_5x4_65536spp_0707070707070707_v1e{ESTIMATOR_VERSION}.exr"
        ))
    );
    let evil = ReferenceKey {
        scene: "../..".into(),
        signal: "".into(),
        ..key()
    };
    let p = evil.relative_path();
    assert!(
        p.components()
            .all(|c| matches!(c, std::path::Component::Normal(_))),
        "{p:?}"
    );
    let v2 = ReferenceKey {
        version: 2,
        ..key()
    };
    assert_ne!(k.relative_path(), v2.relative_path());
    let other_content = ReferenceKey {
        content: SceneHash([8; 32]),
        ..key()
    };
    assert_ne!(k.relative_path(), other_content.relative_path());
}

#[test]
fn default_dir_honours_override() {
    // Only reads the environment; the override variable is unlikely to be set in tests, and
    // whichever branch applies, the result must end in the documented location.
    if let Some(d) = ReferenceCache::default_dir() {
        if std::env::var_os(ReferenceCache::ENV_VAR).is_none() {
            assert!(d.ends_with("vrrt/references"), "{d:?}");
        }
    }
}

#[test]
fn miss_then_hit_scalar_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path().join("refs"));
    let k = key();
    assert_eq!(cache.lookup(&k), Lookup::Miss);
    assert_eq!(cache.load(&k), None);
    let img = test_image(1);
    let path = cache
        .store(&k, img.view(), &StdErr::Scalar(0.0123))
        .unwrap();
    assert_eq!(path, cache.path(&k));
    let hit = cache.load(&k).unwrap();
    assert_eq!(bits(hit.image.data()), bits(img.data()));
    assert_eq!(hit.image.channels(), 1);
    assert_eq!(hit.stderr, StdErr::Scalar(0.0123));
    // The entry is a plain EXR for other tools too.
    assert_eq!(image::read_exr(&path).unwrap().data(), img.data());
    // Other keys still miss.
    assert_eq!(cache.load(&ReferenceKey { frame: 4, ..key() }), None);
    // No temporary files are left behind.
    let leftovers: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
    assert_eq!(leftovers.len(), 1);
}

#[test]
fn hit_with_per_pixel_stderr_rgb() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let k = ReferenceKey {
        signal: "radiance".into(),
        ..key()
    };
    let img = test_image(3);
    for se in [test_image(3), test_image(1)] {
        cache
            .store(&k, img.view(), &StdErr::Image(se.clone()))
            .unwrap();
        let hit = cache.load(&k).unwrap();
        assert_eq!(bits(hit.image.data()), bits(img.data()));
        match hit.stderr {
            StdErr::Image(got) => {
                assert_eq!(got.channels(), se.channels());
                assert_eq!(bits(got.data()), bits(se.data()));
            }
            other => panic!("expected per-pixel stderr, got {other:?}"),
        }
    }
}

#[test]
fn store_rejects_mismatches() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let wrong_size = Image::zeros(4, 4, 1);
    let e = cache
        .store(&key(), wrong_size.view(), &StdErr::Scalar(0.0))
        .unwrap_err();
    assert!(matches!(e, CacheError::Mismatch(_)), "{e}");
    let e = cache
        .store(
            &key(),
            test_image(3).view(),
            &StdErr::Image(Image::zeros(5, 4, 2)),
        )
        .unwrap_err();
    assert!(matches!(e, CacheError::Mismatch(_)), "{e}");
    assert!(matches!(
        cache.store(&key(), Image::zeros(5, 4, 2).view(), &StdErr::Scalar(0.0)),
        Err(CacheError::Mismatch(_))
    ));
    assert_eq!(cache.lookup(&key()), Lookup::Miss);
}

#[test]
fn corrupt_entries_are_misses() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let k = key();
    let path = cache
        .store(&k, test_image(3).view(), &StdErr::Image(test_image(3)))
        .unwrap();
    let good = std::fs::read(&path).unwrap();

    // Truncated at many points, including inside the header and the pixel data.
    for len in [
        0,
        3,
        20,
        good.len() / 3,
        good.len() / 2,
        good.len() - 10,
        good.len() - 1,
    ] {
        std::fs::write(&path, &good[..len]).unwrap();
        assert!(
            matches!(cache.lookup(&k), Lookup::Corrupt(_)),
            "truncated to {len}"
        );
        assert_eq!(cache.load(&k), None);
    }
    // Garbage.
    std::fs::write(&path, b"not an exr at all, just text").unwrap();
    assert!(matches!(cache.lookup(&k), Lookup::Corrupt(_)));
    // Flipped bytes in the compressed pixel data.
    let mut flipped = good.clone();
    let n = flipped.len();
    for b in &mut flipped[n - 40..n - 20] {
        *b ^= 0x5a;
    }
    std::fs::write(&path, &flipped).unwrap();
    match cache.lookup(&k) {
        Lookup::Corrupt(_) => {}
        Lookup::Hit(r) => panic!("damaged entry read as a hit: {:?}", r.image.data().len()),
        Lookup::Miss => panic!("damaged entry read as absent"),
    }
    // A directory where the file should be.
    std::fs::remove_file(&path).unwrap();
    std::fs::create_dir(&path).unwrap();
    assert!(matches!(cache.lookup(&k), Lookup::Corrupt(_)));
    std::fs::remove_dir(&path).unwrap();

    // Storing again repairs the entry.
    cache
        .store(&k, test_image(3).view(), &StdErr::Scalar(1.0))
        .unwrap();
    assert!(cache.load(&k).is_some());
}

#[test]
fn every_single_byte_flip_is_caught_or_harmless() {
    // Flip each byte of a stored entry in turn: the lookup must never panic and must never
    // return a hit whose contents differ from what was stored.
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let k = key();
    for stderr in [StdErr::Scalar(0.25), StdErr::Image(test_image(1))] {
        let img = test_image(3);
        let path = cache.store(&k, img.view(), &stderr).unwrap();
        let good = std::fs::read(&path).unwrap();
        let mut caught = 0;
        for i in 0..good.len() {
            let mut bad = good.clone();
            bad[i] ^= 0x10;
            std::fs::write(&path, &bad).unwrap();
            match cache.lookup(&k) {
                Lookup::Hit(r) => {
                    assert_eq!(bits(r.image.data()), bits(img.data()), "byte {i}");
                    assert_eq!(r.stderr, stderr, "byte {i}");
                }
                Lookup::Corrupt(_) => caught += 1,
                Lookup::Miss => panic!("byte {i}: miss"),
            }
        }
        assert!(caught > good.len() / 2, "{caught} of {}", good.len());
    }
}

#[test]
fn entry_of_another_key_is_rejected() {
    // Two keys whose sanitised paths collide ("a b" vs "a_b") must not read each other.
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let a = ReferenceKey {
        scene: "a b".into(),
        ..key()
    };
    let b = ReferenceKey {
        scene: "a_b".into(),
        ..key()
    };
    assert_eq!(cache.path(&a), cache.path(&b));
    cache
        .store(&a, test_image(1).view(), &StdErr::Scalar(0.5))
        .unwrap();
    assert!(cache.load(&a).is_some());
    assert!(matches!(cache.lookup(&b), Lookup::Corrupt(m) if m.contains("another key")));
}

#[test]
fn plain_exr_without_key_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let k = key();
    let path = cache.path(&k);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::write_exr(&path, test_image(1).view()).unwrap();
    assert!(matches!(cache.lookup(&k), Lookup::Corrupt(m) if m.contains(KEY_ATTRIBUTE)));
}

#[test]
fn store_into_unwritable_location_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, b"x").unwrap();
    let cache = ReferenceCache::new(blocker.join("below"));
    let e = cache
        .store(&key(), test_image(1).view(), &StdErr::Scalar(0.0))
        .unwrap_err();
    assert!(matches!(e, CacheError::Io { .. }), "{e}");
}
