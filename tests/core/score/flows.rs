//! Flow sources: stored flows, DIS estimates (kept for the neighbouring frames) and the
//! fallback from stored to estimated; plus the model key of a checkpoint file.

use std::sync::Arc;

use vadscope::flow::{DisPreset, FlowField};
use vadscope::score::{FlowProvider, FlowSource, ModelKey};
use vadscope::sequence::{FrameRecord, Scenario};

use crate::support::scenario::{ScenarioBuilder, square_box, square_record};

/// Five frames of the moving square; a stored flow (u = 4 everywhere) at frames 1 and 2 only.
fn scenario(dir: &std::path::Path) -> Scenario {
    let frame = |k: u64| {
        let flow = (1..=2).contains(&k).then(|| {
            let mut f = FlowField::zeros(96, 64);
            f.uv.chunks_mut(2).for_each(|px| px[0] = 4.0);
            f
        });
        FrameRecord {
            flow,
            anomalous: None,
            ..square_record(k)
        }
    };
    let folder = ScenarioBuilder::new()
        .frames((0..5).map(frame))
        .write(&dir.join("s"));
    Scenario::open(&folder).expect("open")
}

#[test]
fn stored_estimated_and_fallback_flows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let s = scenario(dir.path());

    let mut stored = FlowProvider::new(&s, FlowSource::Stored);
    assert_eq!(
        stored.flow(1).expect("read").expect("stored").at(10, 10),
        [4.0, 0.0]
    );
    assert!(
        stored.flow(3).expect("read").is_none(),
        "missing stored flow"
    );
    assert!(stored.flow(0).expect("read").is_none());

    let mut estimated = FlowProvider::new(&s, FlowSource::Estimated(DisPreset::Ultrafast));
    assert!(
        estimated.flow(0).expect("estimate").is_none(),
        "no frame before frame 0"
    );
    let f3 = estimated.flow(3).expect("estimate").expect("some");
    assert_eq!((f3.width, f3.height), (96, 64));
    let [u, v] = f3.at(square_box(2).x1 as u32 + 8, 32);
    assert!(
        u > 1.0 && v.abs() < 1.0,
        "the square moves 4 px to the right: ({u}, {v})"
    );
    let again = estimated.flow(3).expect("estimate").expect("some");
    assert!(Arc::ptr_eq(&f3, &again), "kept, not estimated twice");
    let f1 = estimated.flow(1).expect("estimate").expect("some");
    let stored_f1 = stored.flow(1).expect("read").expect("stored");
    assert_ne!(f1.uv, stored_f1.uv, "stored flows are ignored");
    let cached = vadscope::flow::cache::read_cached_flow(&s, DisPreset::Ultrafast, 3)
        .expect("read cache")
        .expect("estimates go to the flow cache");
    assert_eq!(cached.uv, f3.uv, "scoring reads what the cache holds");

    let mut fallback = FlowProvider::new(&s, FlowSource::StoredElseEstimated(DisPreset::Ultrafast));
    assert_eq!(
        fallback.flow(2).expect("read").expect("stored").at(50, 5),
        [4.0, 0.0]
    );
    assert!(
        fallback.flow(4).expect("estimate").is_some(),
        "estimated where nothing is stored"
    );

    assert_eq!(FlowSource::Stored.key(), "stored");
    assert_eq!(FlowSource::default().key(), "stored-dis-medium");
    assert_eq!(FlowSource::Estimated(DisPreset::Medium).key(), "dis-medium");
    assert_eq!(
        FlowSource::StoredElseEstimated(DisPreset::Fast).key(),
        "stored-dis-fast"
    );
}

#[test]
fn model_key_hashes_the_checkpoint_contents() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (a, b, c) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );
    std::fs::write(&a, vec![7u8; 3 << 20]).expect("write");
    std::fs::write(&b, vec![7u8; 3 << 20]).expect("write");
    let mut other = vec![7u8; 3 << 20];
    other[(3 << 20) - 1] = 8;
    std::fs::write(&c, other).expect("write");
    let key = |p| ModelKey::of_checkpoint(p).expect("hash");
    assert_eq!(key(&a), key(&b));
    assert_ne!(
        key(&a),
        key(&c),
        "a change in the last byte changes the key"
    );
    let error = ModelKey::of_checkpoint(&dir.path().join("missing")).expect_err("no file");
    assert!(error.to_string().contains("missing"), "{error}");
}
