//! The score cache on disk: round trip, lookup through a scenario, staleness, and clear
//! errors naming the file for truncated, corrupted or foreign files.

use std::path::Path;

use vadscope::model::{BandStats, ScoreStats, ScoreTails};
use vadscope::score::cache::{frame_ids_hash, map_stride};
use vadscope::score::{
    CacheKey, CacheWriter, ModelKey, ObjectMaps, ScoreCache, ScoreTable, write_cache,
};
use vadscope::sequence::Scenario;

use crate::support::scenario::square_scenario;
use crate::support::score::{object, table};

/// Maps whose values identify the object (f16-exact for the reconstructed flow).
fn maps_of(k: usize) -> ObjectMaps {
    ObjectMaps {
        flow_error: (0..64).map(|i| (k * 1000 + i) as f32 * 0.37).collect(),
        frame_error: (0..64).map(|i| 1e-6 * (k + i) as f32).collect(),
        predicted: (0..192).map(|i| ((k * 31 + i) % 256) as u8).collect(),
        recon_flow: (0..128)
            .map(|i| (i as f32 - 64.0) * 0.25 + k as f32)
            .collect(),
    }
}

fn sample_table() -> ScoreTable {
    table(
        &[
            vec![object([1.0, 2.0, 30.0, 20.0], 12.5, 0.75)],
            vec![],
            vec![
                object([0.0, 0.0, 8.0, 8.0], 3.0, 4.0),
                object([5.5, 6.25, 9.0, 40.0], 1e9, 1e-9),
            ],
            vec![],
        ],
        (64, 48),
        4,
        2,
    )
}

fn write_sample(path: &Path) -> (ScoreTable, Vec<ObjectMaps>) {
    let t = sample_table();
    let maps: Vec<ObjectMaps> = (0..t.objects.len()).map(maps_of).collect();
    write_cache(path, &t, &maps).expect("write");
    (t, maps)
}

#[test]
fn tables_and_maps_round_trip() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("scores").join("a.vsc");
    let (t, maps) = write_sample(&path);
    let cache = ScoreCache::open(&path).expect("open");
    assert_eq!(cache.table(), &t);
    assert_eq!(cache.path(), path);
    assert_eq!(cache.frame_maps(0).expect("maps"), vec![maps[0].clone()]);
    assert!(cache.frame_maps(1).expect("maps").is_empty());
    assert_eq!(cache.frame_maps(2).expect("maps"), maps[1..3].to_vec());
    assert_eq!(cache.read_maps(1, 2).expect("maps"), maps[1..3].to_vec());
    assert!(cache.read_maps(2, 2).is_err(), "past the last object");
    assert!(cache.frame_maps(4).is_err());
    let expected_len = 64 + 3 * map_stride(8);
    assert!(std::fs::metadata(&path).expect("stat").len() > expected_len as u64);
    let leftovers: Vec<_> = std::fs::read_dir(path.parent().expect("dir"))
        .expect("list")
        .filter_map(Result::ok)
        .map(|e| e.file_name())
        .collect();
    assert_eq!(
        leftovers.len(),
        1,
        "no temporary files stay behind: {leftovers:?}"
    );
}

#[test]
fn score_bands_and_tail_tables_round_trip() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("banded.vsc");
    let mut t = sample_table();
    let tails = |scale: f64| {
        let scores: Vec<f64> = (1..=50).map(|i| scale * f64::from(i).powi(3)).collect();
        ScoreTails::of(&scores, &scores[..40]).expect("tables")
    };
    let band = |cubes, tails| BandStats {
        cubes,
        flow_score: ScoreStats {
            mean: 2.5,
            std: 0.125,
        },
        frame_score: ScoreStats {
            mean: 1e-3,
            std: 7.0,
        },
        tails,
    };
    let training = &mut t.meta.training;
    training.tails = Some(tails(1.0));
    training.bands = vec![band(40, Some(tails(0.5))), band(2, None)];
    let maps: Vec<ObjectMaps> = (0..t.objects.len()).map(maps_of).collect();
    write_cache(&path, &t, &maps).expect("write");
    assert_eq!(ScoreCache::open(&path).expect("open").table(), &t);
}

#[test]
fn rewriting_replaces_the_file_atomically_and_unfinished_writers_leave_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("a.vsc");
    write_sample(&path);
    let mut other = sample_table();
    other.objects[0].s_r = 99.0;
    let maps: Vec<ObjectMaps> = (0..3).map(maps_of).collect();
    write_cache(&path, &other, &maps).expect("rewrite");
    assert_eq!(
        ScoreCache::open(&path).expect("open").table().objects[0].s_r,
        99.0
    );

    let fresh = dir.path().join("b.vsc");
    let mut writer = CacheWriter::create(&fresh, 8).expect("create");
    writer.push_maps(&maps[0]).expect("push");
    drop(writer);
    assert!(!fresh.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).expect("list").count(),
        1,
        "temporary file removed"
    );

    let writer = CacheWriter::create(&fresh, 8).expect("create");
    let error = writer
        .finish(&sample_table())
        .expect_err("no maps were written");
    assert!(error.to_string().contains("b.vsc"), "{error}");
    let mut writer = CacheWriter::create(&fresh, 8).expect("create");
    assert!(
        writer.push_maps(&ObjectMaps::zeros(4)).is_err(),
        "maps of another patch size"
    );
}

fn assert_cache_error(path: &Path, needle: &str) {
    let error = ScoreCache::open(path).expect_err("must fail");
    let message = error.to_string();
    assert!(
        message.contains(&path.display().to_string()),
        "names the file: {message}"
    );
    assert!(message.contains(needle), "says {needle:?}: {message}");
}

#[test]
fn truncated_and_corrupt_files_are_named_errors() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("a.vsc");
    write_sample(&path);
    let good = std::fs::read(&path).expect("read");

    std::fs::write(&path, &good[..good.len() - 10]).expect("write");
    assert_cache_error(&path, "truncated");
    std::fs::write(&path, &good[..40]).expect("write");
    assert_cache_error(&path, "truncated");
    std::fs::write(&path, b"").expect("write");
    assert_cache_error(&path, "truncated");

    let mut bad = good.clone();
    bad[0] = b'X';
    std::fs::write(&path, &bad).expect("write");
    assert_cache_error(&path, "not a vadscope score cache");

    let mut bad = good.clone();
    bad[8] = 9;
    std::fs::write(&path, &bad).expect("write");
    assert_cache_error(&path, "version 9");

    let mut bad = good.clone();
    bad[20] ^= 1;
    std::fs::write(&path, &bad).expect("write");
    assert_cache_error(&path, "header checksum");

    let mut bad = good.clone();
    let last = bad.len() - 3;
    bad[last] ^= 0x40;
    std::fs::write(&path, &bad).expect("write");
    assert_cache_error(&path, "table checksum");

    // A damaged map block is found when that frame's maps are read.
    let mut bad = good.clone();
    bad[64 + map_stride(8) + 5] ^= 0x01;
    std::fs::write(&path, &bad).expect("write");
    let cache = ScoreCache::open(&path).expect("tables are intact");
    cache.frame_maps(0).expect("object 0 is intact");
    let error = cache
        .frame_maps(2)
        .expect_err("object 1 is damaged")
        .to_string();
    assert!(
        error.contains("object 1") && error.contains("a.vsc"),
        "{error}"
    );

    // A header with a valid checksum that claims a patch size no model has: refused
    // before any size is computed from it.
    let mut bad = good.clone();
    bad[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    let checksum = vadscope::fnv::fnv1a64(&bad[..56]);
    bad[56..64].copy_from_slice(&checksum.to_le_bytes());
    std::fs::write(&path, &bad).expect("write");
    assert_cache_error(&path, "patch size 4294967295");

    let missing = dir.path().join("missing.vsc");
    let error = ScoreCache::open(&missing).expect_err("no file").to_string();
    assert!(error.contains("missing.vsc"), "{error}");
}

#[test]
fn inconsistent_tables_are_refused_when_writing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut t = sample_table();
    t.frames[2].objects = 1;
    let maps: Vec<ObjectMaps> = (0..3).map(maps_of).collect();
    let error = write_cache(&dir.path().join("a.vsc"), &t, &maps).expect_err("inconsistent");
    assert!(error.to_string().contains("starts at object"), "{error}");
    let mut t = sample_table();
    t.batches.pop();
    assert!(write_cache(&dir.path().join("b.vsc"), &t, &maps).is_err());
}

#[test]
fn lookup_finds_the_cache_of_a_key_and_rejects_stale_ones() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = square_scenario(4).write(&dir.path().join("scenario"));
    let scenario = Scenario::open(&root).expect("open scenario");
    let key = CacheKey {
        scenario: scenario.name().to_string(),
        model: ModelKey(0xfeed),
        boxes: "gt".into(),
        flow: "stored".into(),
    };
    assert!(
        ScoreCache::lookup(&scenario, &key)
            .expect("lookup")
            .is_none()
    );

    let mut t = sample_table();
    t.meta.key = key.clone();
    t.meta.frame_width = 96;
    t.meta.frame_height = 64;
    t.meta.frame_ids_hash = frame_ids_hash((0..4).filter_map(|i| scenario.frame_id(i)));
    let maps: Vec<ObjectMaps> = (0..3).map(maps_of).collect();
    let path = key.path_in(&scenario.cache_dir().expect("cache dir"));
    assert!(
        path.starts_with(&root),
        "inside the scenario's .vadscope folder"
    );
    write_cache(&path, &t, &maps).expect("write");
    let found = ScoreCache::lookup(&scenario, &key)
        .expect("lookup")
        .expect("present");
    assert_eq!(found.table().objects.len(), 3);

    let other = CacheKey {
        flow: "dis-medium".into(),
        ..key.clone()
    };
    assert!(
        ScoreCache::lookup(&scenario, &other)
            .expect("lookup")
            .is_none(),
        "another file name"
    );

    t.meta.frame_ids_hash ^= 1;
    write_cache(&path, &t, &maps).expect("write");
    let error = ScoreCache::lookup(&scenario, &key)
        .expect_err("stale")
        .to_string();
    assert!(
        error.contains("stale") && error.contains("frame ids"),
        "{error}"
    );

    let mut five = sample_table();
    five.frames.push(five.frames[3]);
    five.meta.key = key.clone();
    write_cache(&path, &five, &maps).expect("write");
    let error = ScoreCache::lookup(&scenario, &key)
        .expect_err("stale")
        .to_string();
    assert!(error.contains("5 frames scored"), "{error}");
}
