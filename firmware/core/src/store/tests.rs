use super::*;

const PTS: [[i32; 3]; 4] = [
    [0, 0, 0],
    [10_000, 0, 0],
    [0, 10_000, 0],
    [10_000, 10_000, 0],
];

fn rig_crc(t: u16) -> u32 {
    let pts: [[i32; 3]; 8] = core::array::from_fn(|i| PTS[i % 4]);
    lm_proto::rig_crc32(&Positions::from_points(&pts[..usize::from(t)]))
}

fn begin(slot: u8, steps: u16, t: u16) -> BeginUpload {
    BeginUpload {
        slot,
        header: UploadHeader {
            steps,
            transducers: t,
            period_us: 200_000,
            center_um: [0, 0, 150_000],
            foci_per_step: 1,
            sound_speed_mm_s: 340_000,
            max_offset_um: 20_000,
            intensity: 255,
        },
        encoding: Encoding::Raw,
        encoded_len: u32::from(steps) * u32::from(t),
        rig_crc32: rig_crc(t),
        intensity_table: false,
    }
}

/// Uploads the test rig of `t` (≤ 8) transducers.
fn rig(store: &mut Store<'_>, t: u16) {
    store.begin_rig(t, rig_crc(t)).unwrap();
    for first in 0..t {
        let i = usize::from(first) % 4;
        store
            .geometry(first, &Positions::from_points(&PTS[i..i + 1]))
            .unwrap();
    }
    store.commit_rig().unwrap();
}

#[test]
fn raw_upload_commit_and_read_back() {
    let mut mem = [0u8; memory_bytes(64, 4)];
    let mut st = Store::new(&mut mem, 4).unwrap();
    assert_eq!(st.slot_bytes(), 64);
    rig(&mut st, 4);
    let data: [u8; 12] = core::array::from_fn(|i| i as u8 * 7);
    st.begin(&begin(1, 3, 4)).unwrap();
    assert_eq!(st.chunk(1, 0, &data[..5]), Ok(()));
    assert_eq!(
        st.chunk(1, 0, &data[..5]),
        Ok(()),
        "duplicate of last chunk"
    );
    assert_eq!(st.chunk(1, 0, &data[1..6]), Err(NackCode::OutOfOrder));
    assert_eq!(st.chunk(1, 1, &data[1..4]), Ok(()), "identical inner range");
    assert_eq!(
        st.chunk(1, 3, &data[3..7]),
        Err(NackCode::OutOfOrder),
        "overlap"
    );
    assert_eq!(st.chunk(1, 6, &data[6..]), Err(NackCode::OutOfOrder), "gap");
    assert_eq!(st.chunk(1, 5, &data[5..]), Ok(()));
    assert_eq!(st.chunk(1, 12, &[1]), Err(NackCode::OutOfRange));
    assert_eq!(st.commit(1, 1), Err(NackCode::CrcMismatch));
    assert!(!st.is_committed(1));
    assert_eq!(st.free_bytes(), 64, "a failed upload frees its space");
    assert_eq!(
        st.commit(1, lm_proto::crc32(&data)),
        Err(NackCode::NoUpload)
    );
    st.begin(&begin(1, 3, 4)).unwrap();
    assert_eq!(
        st.commit(1, lm_proto::crc32(&data)),
        Err(NackCode::Incomplete)
    );
    st.chunk(1, 0, &data).unwrap();
    st.commit(1, lm_proto::crc32(&data)).unwrap();
    assert!(st.is_committed(1));
    assert_eq!(st.commit(1, lm_proto::crc32(&data)), Ok(()), "repeat");
    assert_eq!(st.commit(1, 0), Err(NackCode::NoUpload), "other CRC");
    assert!(st.is_committed(1));
    assert_eq!(st.step(1, 2), Some(&data[8..12]));
    assert_eq!(st.step(1, 3), None);
    assert_eq!(&st.positions(1).unwrap()[12..16], &10_000i32.to_le_bytes());
    assert_eq!(st.form(1), Some(Form::Raw));
}

#[test]
fn refuses_bad_headers() {
    let mut mem = [0u8; memory_bytes(64, 4)];
    let mut st = Store::new(&mut mem, 4).unwrap();
    assert_eq!(st.begin(&begin(0, 1, 4)), Err(NackCode::NoRig));
    rig(&mut st, 4);
    assert_eq!(st.begin(&begin(SLOTS as u8, 1, 1)), Err(NackCode::BadSlot));
    assert_eq!(st.begin(&begin(0, 17, 4)), Err(NackCode::TooLarge));
    assert_eq!(st.begin(&begin(0, 1, 5)), Err(NackCode::TooLarge));
    assert_eq!(st.begin(&begin(0, 0, 4)), Err(NackCode::OutOfRange));
    for speed in [0, 99_999, 2_000_001, u32::MAX] {
        let mut b = begin(0, 1, 4);
        b.header.sound_speed_mm_s = speed;
        assert_eq!(st.begin(&b), Err(NackCode::OutOfRange), "{speed} mm/s");
    }
    let mut b = begin(0, 2, 4);
    b.encoded_len = 7;
    assert_eq!(st.begin(&b), Err(NackCode::OutOfRange));
    b.encoding = Encoding::Delta;
    b.encoded_len = 0;
    assert_eq!(st.begin(&b), Err(NackCode::OutOfRange));
    let mut b = begin(0, 2, 4);
    b.header.max_offset_um = 0;
    assert_eq!(st.begin(&b), Err(NackCode::OutOfRange));
    // Another rig: its CRC, or its transducer count.
    let mut b = begin(0, 2, 4);
    b.rig_crc32 ^= 1;
    assert_eq!(st.begin(&b), Err(NackCode::RigMismatch));
    assert_eq!(st.begin(&begin(0, 2, 3)), Err(NackCode::RigMismatch));
    assert_eq!(st.chunk(0, 0, &[0]), Err(NackCode::NoUpload));
    assert!(Store::new(&mut [0u8; 10], 4).is_err());
}

#[test]
fn rig_needs_every_position_and_its_crc() {
    let mut mem = [0u8; memory_bytes(64, 4)];
    let mut st = Store::new(&mut mem, 4).unwrap();
    assert_eq!(st.commit_rig(), Err(NackCode::NoUpload));
    st.begin_rig(4, rig_crc(4)).unwrap();
    let p = Positions::from_points(&PTS[..3]);
    st.geometry(0, &p).unwrap();
    assert_eq!(st.geometry(2, &p), Err(NackCode::OutOfRange));
    assert_eq!(st.commit_rig(), Err(NackCode::Incomplete));
    st.geometry(3, &Positions::from_points(&PTS[3..])).unwrap();
    assert_eq!(st.commit_rig(), Ok(()));
    assert_eq!(st.rig(), Some((4, rig_crc(4))));
    assert_eq!(st.commit_rig(), Ok(()), "repeat");
    let p = Positions::from_points(&PTS[2..]);
    assert_eq!(st.geometry(2, &p), Ok(()), "identical repeat");
    assert_eq!(
        st.geometry(1, &p),
        Err(NackCode::NoUpload),
        "other positions"
    );
    // A wrong CRC drops the rig.
    st.begin_rig(4, 1).unwrap();
    st.geometry(0, &Positions::from_points(&PTS)).unwrap();
    assert_eq!(st.commit_rig(), Err(NackCode::CrcMismatch));
    assert_eq!(st.rig(), None);
    assert_eq!(st.begin_rig(0, 0), Err(NackCode::OutOfRange));
    assert_eq!(st.begin_rig(5, 0), Err(NackCode::TooLarge));
}

#[test]
fn delta_stream_kept_or_expanded_plays_the_same_steps() {
    let t = 5u16;
    let steps = 9u16;
    let raw: [u8; 45] = core::array::from_fn(|i| ((i / 5) * (i % 5 + 1) * 3) as u8);
    let mut enc = [0u8; 256];
    let n = lm_proto::codec::encode(Encoding::Delta, &raw, usize::from(t), &mut enc).unwrap();
    // 60 bytes: 45 raw would leave 15 < 45 free, so the entry stays Delta;
    // 200: expanded to Raw (155 ≥ 150 free).
    for (arena, form) in [(60, Form::Delta), (200, Form::Raw)] {
        let mut mem = [0u8; memory_bytes(200, 5)];
        let mut st = Store::new(&mut mem[..memory_bytes(arena, 5)], 5).unwrap();
        rig(&mut st, 5);
        let mut b = begin(0, steps, t);
        b.encoding = Encoding::Delta;
        b.encoded_len = n as u32;
        st.begin(&b).unwrap();
        assert!(n <= 3 * CHUNK_LOG, "every chunk stays logged");
        let mut off = 0;
        for piece in enc[..n].chunks(3) {
            st.chunk(0, off as u32, piece).unwrap();
            off += piece.len();
        }
        // Repeats of any received chunk are acked; other bytes are not.
        assert_eq!(st.chunk(0, 0, &enc[..3]), Ok(()));
        assert_eq!(st.chunk(0, 3, &enc[3..6]), Ok(()));
        assert_eq!(st.chunk(0, 3, &[0xAA; 3]), Err(NackCode::OutOfOrder));
        st.commit(0, lm_proto::crc32(&raw)).unwrap();
        assert_eq!(st.form(0), Some(form));
        // Twice round, then a jump back and a skip ahead.
        for k in (0..steps).chain(0..steps).chain([4, 2, 8, 0]) {
            let s = usize::from(k) * 5;
            assert_eq!(st.step(0, k).unwrap(), &raw[s..s + 5], "{form:?} step {k}");
        }
    }
}
