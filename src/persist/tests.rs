use super::*;
use crate::registry::{find, Value};

use crate::test_rng::TestRng;

/// Settings that differ from the defaults in many entries, `k` making them distinct.
pub(super) fn variant(k: u32) -> PipelineSettings {
    let mut s = PipelineSettings::default();
    let kf = k as f32;
    s.filter.gate.norm_tolerance = 0.01 + 0.001 * (k % 100) as f32;
    s.filter.init.initial_yaw = 0.01 * (k % 300) as f32;
    s.filter.rest.min_blocks = (1 + k % 10) as u8;
    s.filter.rest.enabled = k % 2 == 0;
    s.conditioning.gyro_offset = ekf_core::Vec3::new(0.001 * kf.sin(), -0.002, 0.003);
    s.conditioning.accel_calibration = ekf_core::accel_calibration::AccelCalibration::INEMO_BOARD;
    s.conditioning.accel_axes = ekf_core::axis_map::AxisMap::new([1, 0, 2], [1, 1, -1]).unwrap();
    s.depth.water_density_kg_m3 = 998.0 + (k % 50) as f32;
    s.output_rate_hz = (1 + k % 50) as u16;
    s.filter_rate_hz = 100;
    s
}

fn source_seq(l: &Loaded) -> Option<u32> {
    match l.source {
        Source::Flash { seq, .. } => Some(seq),
        Source::Defaults => None,
    }
}

#[test]
fn empty_flash_loads_defaults() {
    let f = SimFlash::new();
    let l = load(&f);
    assert_eq!(l.settings, PipelineSettings::default());
    assert_eq!(l.source, Source::Defaults);
}

#[test]
fn saves_alternate_pages_and_load_the_newest_exactly() {
    let mut f = SimFlash::new();
    let mut expect_page = Page::A;
    for k in 1..=6u32 {
        let s = variant(k);
        let saved = save(&mut f, &s).unwrap();
        assert_eq!(saved, Saved { page: expect_page, seq: k });
        expect_page = expect_page.other();
        let l = load(&f);
        assert_eq!(l.settings, s);
        assert_eq!(l.source, Source::Flash { page: saved.page, seq: k });
        assert_eq!((l.skipped, l.missing), (0, 0));
    }
    // A record is a few hundred bytes: well inside a 2 KiB page.
    let (len, count) = payload_size(&PipelineSettings::default());
    assert_eq!(usize::from(count), crate::registry::SETTINGS.len());
    assert!(HEADER_LEN + len + CRC_LEN < 1024, "{len}");
}

#[test]
fn sequence_numbers_wrap() {
    assert!(is_newer(1, 0));
    assert!(is_newer(0, u32::MAX));
    assert!(!is_newer(u32::MAX, 0));
    assert!(!is_newer(5, 5));
    // Exactly half the range apart: neither is newer (the module documentation: `b − a`
    // (mod 2³²) < 2³¹), so `load` keeps page A's record.
    assert!(is_newer(0x7FFF_FFFF, 0) && !is_newer(0, 0x7FFF_FFFF));
    assert!(!is_newer(0x8000_0000, 0) && !is_newer(0, 0x8000_0000));
    assert!(!is_newer(3, 0x8000_0003) && !is_newer(0x8000_0003, 3));
    let mut f = SimFlash::new();
    // A record with sequence u32::MAX in A; the next save goes to B with sequence 0 and wins.
    write_raw(&mut f, Page::A, u32::MAX, FORMAT_VERSION, &[(111, &[7, 0])]);
    assert_eq!(load(&f).settings.output_rate_hz, 7);
    let s = variant(3);
    assert_eq!(save(&mut f, &s).unwrap(), Saved { page: Page::B, seq: 0 });
    assert_eq!(load(&f).settings, s);
    assert_eq!(save(&mut f, &variant(4)).unwrap(), Saved { page: Page::A, seq: 1 });
    assert_eq!(load(&f).settings, variant(4));
    // Two records half the range apart: neither is newer, page A's is taken.
    for (a, b) in [(0, 0x8000_0000), (0x8000_0000, 0)] {
        let mut f = SimFlash::new();
        write_raw(&mut f, Page::A, a, FORMAT_VERSION, &[(111, &[7, 0])]);
        write_raw(&mut f, Page::B, b, FORMAT_VERSION, &[(111, &[9, 0])]);
        let l = load(&f);
        assert_eq!(l.source, Source::Flash { page: Page::A, seq: a });
        assert_eq!(l.settings.output_rate_hz, 7);
    }
}

/// Write a record by hand: any entries, any version.
fn write_raw(f: &mut SimFlash, page: Page, seq: u32, version: u16, entries: &[(u16, &[u8])]) {
    write_payload(f, page, seq, version, &payload_of(entries), entries.len() as u16);
}

/// The payload bytes of `entries` (`id`, length, value).
fn payload_of(entries: &[(u16, &[u8])]) -> Vec<u8> {
    let mut payload = Vec::new();
    for (id, v) in entries {
        payload.extend_from_slice(&id.to_le_bytes());
        payload.push(v.len() as u8);
        payload.extend_from_slice(v);
    }
    payload
}

/// Write a valid record (commit word, CRC) by hand around any payload bytes and entry count.
fn write_payload(f: &mut SimFlash, page: Page, seq: u32, version: u16, payload: &[u8], count: u16) {
    let mut rec = Vec::new();
    rec.extend_from_slice(&version.to_le_bytes());
    rec.extend_from_slice(&seq.to_le_bytes());
    rec.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    rec.extend_from_slice(&count.to_le_bytes());
    rec.extend_from_slice(payload);
    if rec.len() % 2 == 1 {
        rec.push(0);
    }
    let crc = crc32(&rec);
    rec.extend_from_slice(&crc.to_le_bytes());
    let p = f.page_mut(page);
    p.fill(0xFF);
    p[0..2].copy_from_slice(&COMMIT.to_le_bytes());
    p[2..2 + rec.len()].copy_from_slice(&rec);
}

#[test]
fn old_and_new_records_stay_readable() {
    let mut f = SimFlash::new();
    // A record from "another firmware": an unknown id 999, a known id with a wrong length, an
    // out-of-range value, and two good entries; everything else missing.
    let density = 1000.0f32.to_le_bytes();
    let bad_tol = 5.0f32.to_le_bytes();
    write_raw(
        &mut f,
        Page::A,
        1,
        FORMAT_VERSION,
        &[(999, &[1, 2, 3]), (102, &density), (111, &[1]), (20, &bad_tol), (112, &[0])],
    );
    let l = load(&f);
    let mut expect = PipelineSettings::default();
    expect.depth.water_density_kg_m3 = 1000.0;
    expect.sentences.prdid = false;
    assert_eq!(l.settings, expect);
    assert_eq!(l.skipped, 3);
    assert_eq!(usize::from(l.missing), crate::registry::SETTINGS.len() - 2);
    // An unknown format version is not read at all.
    write_raw(&mut f, Page::A, 1, FORMAT_VERSION + 1, &[(102, &density)]);
    assert_eq!(load(&f).source, Source::Defaults);
}

/// A record's entry count and payload length bound what is read: entries past the count are
/// not read; an entry whose value runs past the payload is skipped, and a fragment shorter
/// than an entry's header (id, length) is not an entry. Nothing beyond the payload (the
/// padding, the CRC) is ever taken for an entry.
#[test]
fn the_count_and_the_payload_length_bound_the_entries_read() {
    let density = 1000.0f32.to_le_bytes();
    let mut expect = PipelineSettings::default();
    expect.depth.water_density_kg_m3 = 1000.0;
    let all_but_one = crate::registry::SETTINGS.len() as u16 - 1;
    let loaded = |payload: &[u8], count: u16| {
        let mut f = SimFlash::new();
        write_payload(&mut f, Page::A, 1, FORMAT_VERSION, payload, count);
        let l = load(&f);
        assert_eq!(l.source, Source::Flash { page: Page::A, seq: 1 });
        (l.settings, l.skipped, l.missing)
    };
    // Two good entries, a count of one: the second is not read.
    let two = payload_of(&[(102, &density), (111, &[7, 0])]);
    assert_eq!(loaded(&two, 1), (expect, 0, all_but_one));
    assert_eq!(loaded(&two, 2).0.output_rate_hz, 7);
    // The second entry's value cut after one of its two bytes (payload 11 bytes, then the
    // padding byte 0): skipped, not read as 7 with the padding.
    let mut cut = payload_of(&[(102, &density)]);
    cut.extend_from_slice(&[111, 0, 2, 7]);
    assert_eq!(loaded(&cut, 2), (expect, 1, all_but_one));
    // Only two bytes of the second entry's header: the payload ends there.
    let mut frag = payload_of(&[(102, &density)]);
    frag.extend_from_slice(&[111, 0]);
    assert_eq!(loaded(&frag, 2), (expect, 0, all_but_one));
}

/// A record that fills the 2 KiB page to its last byte is valid (12-byte header, 2032 bytes
/// of payload, 4 bytes of CRC: eight entries of unknown ids, all skipped).
#[test]
fn a_record_filling_the_page_exactly_is_valid() {
    let big = [0u8; 255];
    let mut entries: Vec<(u16, &[u8])> = vec![(999, &big); 7];
    entries.push((998, &big[..223]));
    let payload = payload_of(&entries);
    assert_eq!(HEADER_LEN + payload.len() + CRC_LEN, SIM_PAGE_SIZE);
    let mut f = SimFlash::new();
    write_payload(&mut f, Page::B, 4, FORMAT_VERSION, &payload, 8);
    let l = load(&f);
    assert_eq!(l.source, Source::Flash { page: Page::B, seq: 4 });
    assert_eq!((l.settings, l.skipped), (PipelineSettings::default(), 8));
}

/// A [`SimFlash`] seen through pages of `size` bytes (a smaller part's), or, `deaf`, one that
/// acknowledges every erase and program and changes nothing.
struct Odd {
    inner: SimFlash,
    size: usize,
    deaf: bool,
}

impl Flash for Odd {
    fn page_size(&self) -> usize {
        self.size
    }
    fn read(&self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        if offset + buf.len() > self.size {
            return Err(FlashError::OutOfBounds);
        }
        self.inner.read(page, offset, buf)
    }
    fn erase(&mut self, page: Page) -> Result<(), FlashError> {
        if self.deaf {
            return Ok(());
        }
        self.inner.erase(page)
    }
    fn program(&mut self, page: Page, offset: usize, value: u16) -> Result<(), FlashError> {
        if offset + 2 > self.size {
            return Err(FlashError::OutOfBounds);
        }
        if self.deaf {
            return Ok(());
        }
        self.inner.program(page, offset, value)
    }
}

/// The current record is 510 bytes (`record_size_of_the_current_registry`): a page of
/// exactly that size takes it, a page two bytes smaller is refused as too small before
/// anything is written.
#[test]
fn a_record_larger_than_the_page_is_refused_before_any_write() {
    let s = variant(5);
    let mut f = Odd { inner: SimFlash::new(), size: 510, deaf: false };
    assert_eq!(save(&mut f, &s), Ok(Saved { page: Page::A, seq: 1 }));
    assert_eq!(load(&f).settings, s);
    let mut f = Odd { inner: SimFlash::new(), size: 508, deaf: false };
    assert_eq!(save(&mut f, &s), Err(SaveError::TooLarge));
    assert_eq!(f.inner.steps, 0);
}

/// A flash that acknowledges the writes of a save but keeps its old contents: the old record
/// read back is not the one just written, so the save fails (`SAVE` must not report it done).
#[test]
fn a_save_that_never_reached_the_flash_fails_its_verification() {
    let mut inner = SimFlash::new();
    save(&mut inner, &variant(1)).unwrap(); // page A, seq 1
    save(&mut inner, &variant(2)).unwrap(); // page B, seq 2
    let mut f = Odd { inner, size: SIM_PAGE_SIZE, deaf: true };
    // The save goes to page A, which still holds the valid record of sequence 1.
    assert_eq!(save(&mut f, &variant(3)), Err(SaveError::Verify));
    assert_eq!(load(&f).settings, variant(2));
}

/// A flash with one record of `settings` in `page`, sequence `seq`, that lacks the settings
/// `missing` (as a firmware from before they existed wrote it).
fn record_without(settings: &PipelineSettings, missing: &[u16], page: Page, seq: u32) -> SimFlash {
    let values: Vec<(u16, Vec<u8>)> = crate::registry::SETTINGS
        .iter()
        .filter(|s| !missing.contains(&s.id))
        .map(|s| {
            let mut buf = [0u8; 12];
            let n = s.encode(&s.get(settings), &mut buf);
            (s.id, buf[..n].to_vec())
        })
        .collect();
    let entries: Vec<(u16, &[u8])> = values.iter().map(|(id, v)| (*id, v.as_slice())).collect();
    let mut f = SimFlash::new();
    write_raw(&mut f, page, seq, FORMAT_VERSION, &entries);
    f
}

/// A record saved by the firmware before the motion-adaptive EKF settings (ids 14, 67, 68,
/// 69; format version 1 then as now): every setting's entry it had, with that firmware's
/// defaults — the source's gate, 1 ± 0.05 g. It loads in full, the settings it lacks keep their
/// defaults (counted as missing: 14, 67 and 57, `ekf.gyro_scale_error`; 68 and 69 are retired,
/// and so are its χ² 16 and the other gate settings but the tolerance: the next test), and the
/// saved gate stays what was saved.
#[test]
fn a_record_from_before_the_new_ekf_settings_loads_with_their_defaults() {
    const NEW: [u16; 3] = [14, 67, 57];
    let mut old = PipelineSettings::default();
    old.filter.gate.norm_tolerance = ekf_core::settings::GateSettings::SOURCE.norm_tolerance;
    old.depth.water_density_kg_m3 = 998.0;
    let f = record_without(&old, &NEW, Page::A, 7);
    let l = load(&f);
    assert_eq!(l.source, Source::Flash { page: Page::A, seq: 7 });
    assert_eq!((l.skipped, l.missing), (0, NEW.len() as u16));
    assert_eq!(l.settings, old);
    assert_eq!(l.settings.filter.gate.norm_tolerance, 0.05);
    let d = PipelineSettings::default();
    assert_eq!(l.settings.filter.init.moving_bias_sigma, d.filter.init.moving_bias_sigma);
    assert_eq!(l.settings.filter.ekf.accel_time_constant, d.filter.ekf.accel_time_constant);
    assert_eq!(l.settings.filter.ekf.gyro_scale_error, d.filter.ekf.gyro_scale_error);
}

/// The retired settings, with their flash ids, the values their firmware saved by default
/// (internal units: s, rad/s, g², s; g, χ², s, s, s; a factor) and the id each followed in
/// that firmware's table. The ids are never reused.
const RETIRED: [(u16, &str, f32, u16); 12] = [
    (58, "ekf.vib_time_constant", 1.5, 67),
    (59, "ekf.vib_rate", 0.261_799_4, 58), // 15 °/s
    (68, "ekf.motion_scale", 1e-3, 59),
    (69, "ekf.motion_time_constant", 1.0, 68),
    (21, "gate.jump", 0.05, 20),
    (22, "gate.innovation_chi2", 1e6, 21),
    (23, "gate.holdoff", 0.1, 22),
    (24, "gate.reacquire", 2.0, 23),
    (25, "gate.long_reject", 10.0, 24),
    (61, "ekf.accel_var_scale", 1.0, 60),
    (46, "rest.bias_meas_floor", 8.726_646e-5, 45), // 0.005 °/s
    (65, "ekf.initial_yaw_sigma", 0.087_266_46, 64), // 5°
];

/// A record saved by the firmware before the fixed low-pass (format version 1 then as now):
/// every setting's entry but `ekf.gyro_scale_error` (id 57), its own
/// `ekf.accel_time_constant` (1.75 s), and the entries of the ten settings it had that are
/// now retired (issue #26's four, issue #36's six). Those ten are skipped, and only those (an
/// id that were reused, or a load that took an unknown id, would change the count or the
/// settings); every other setting is kept as saved, `ekf.gyro_scale_error` at its default (the
/// one missing).
#[test]
fn a_record_with_the_retired_ekf_settings_skips_exactly_them() {
    // The registry's list of retired settings (which the host tools skip) is this one.
    let registry: Vec<(u16, &str)> =
        crate::registry::RETIRED.iter().map(|r| (r.id, r.name)).collect();
    assert_eq!(RETIRED.map(|(id, name, _, _)| (id, name)).to_vec(), registry);
    for (id, name, _, _) in RETIRED {
        assert!(crate::registry::by_id(id).is_none(), "retired id {id} ({name}) reused");
        assert!(find(name).is_none(), "{name} is back");
    }
    let mut old = variant(8);
    old.filter.ekf.accel_time_constant = 1.75;
    old.filter.ekf.bias_random_walk *= 2.0;
    let mut entries: Vec<(u16, Vec<u8>)> = crate::registry::SETTINGS
        .iter()
        .filter(|s| s.id != 57)
        .map(|s| {
            let mut buf = [0u8; 12];
            let n = s.encode(&s.get(&old), &mut buf);
            (s.id, buf[..n].to_vec())
        })
        .collect();
    // That firmware wrote its entries in its table's order: each retired one after the one it
    // followed then.
    for (id, _, v, after) in RETIRED {
        let at = entries.iter().position(|(i, _)| *i == after).unwrap() + 1;
        entries.insert(at, (id, v.to_le_bytes().to_vec()));
    }
    let entries: Vec<(u16, &[u8])> = entries.iter().map(|(id, v)| (*id, v.as_slice())).collect();
    let mut f = SimFlash::new();
    write_raw(&mut f, Page::B, 12, FORMAT_VERSION, &entries);
    let l = load(&f);
    assert_eq!(l.source, Source::Flash { page: Page::B, seq: 12 });
    assert_eq!((l.skipped, l.missing), (RETIRED.len() as u16, 1));
    assert_eq!(l.settings, old);
    assert_eq!(l.settings.filter.ekf.accel_time_constant, 1.75);
    assert_eq!(
        l.settings.filter.ekf.gyro_scale_error,
        PipelineSettings::default().filter.ekf.gyro_scale_error
    );
    // The next save writes no retired id: the record loads with nothing skipped or missing.
    save(&mut f, &l.settings).unwrap();
    let again = load(&f);
    assert_eq!((again.settings, again.skipped, again.missing), (old, 0, 0));
}

/// The heart of the matter: a power cut after every single write step of a save, clean or
/// leaving the interrupted step half done, from an empty flash, one record and two records.
#[test]
fn a_power_cut_at_any_step_of_a_save_keeps_the_old_or_the_new_settings() {
    let mut cases = 0;
    for history in 0..3u32 {
        let mut base = SimFlash::new();
        let mut old = PipelineSettings::default();
        for k in 0..history {
            old = variant(10 + k);
            save(&mut base, &old).unwrap();
        }
        let new = variant(99);
        // Steps of a complete save.
        let mut probe = base.clone();
        let before = probe.steps;
        save(&mut probe, &new).unwrap();
        let total = probe.steps - before;
        assert!(total > 100, "{total}");
        for torn in [false, true] {
            for n in 0..=total {
                let mut f = base.clone();
                f.cut_power_after(n, torn);
                let r = save(&mut f, &new);
                assert_eq!(r.is_ok(), n == total, "n {n} of {total}: {r:?}");
                f.power_on();
                let l = load(&f);
                if n == total {
                    assert_eq!(l.settings, new);
                } else {
                    assert!(
                        l.settings == old,
                        "history {history}, torn {torn}: cut after {n} of {total} steps lost \
                         the old settings"
                    );
                    assert_eq!(source_seq(&l), (history > 0).then_some(history));
                }
                // The store keeps working after the cut.
                let newer = variant(123);
                save(&mut f, &newer).unwrap();
                assert_eq!(load(&f).settings, newer);
                cases += 1;
            }
        }
    }
    assert!(cases > 600, "{cases}");
}

/// Random chains of saves, each cut at a random step (or not): the loaded settings are always
/// the last completed save's or the interrupted save's, never anything else.
#[test]
fn random_chains_of_interrupted_saves_never_lose_the_last_good_settings() {
    let mut rng = TestRng::new(7);
    for _ in 0..40 {
        let mut f = SimFlash::new();
        let mut good = PipelineSettings::default();
        for k in 0..25u32 {
            let candidate = variant((rng.next_u64() >> 32) as u32 % 1000 + k);
            let cut = rng.below(400);
            let torn = (rng.next_u64() >> 32) as u32 % 2 == 0;
            f.cut_power_after(cut, torn);
            let r = save(&mut f, &candidate);
            f.power_on();
            let l = load(&f);
            if r.is_ok() {
                assert_eq!(l.settings, candidate);
            } else {
                assert!(l.settings == good || l.settings == candidate);
            }
            good = l.settings;
        }
    }
}

#[test]
fn random_bit_flips_in_one_page_are_detected() {
    let mut rng = TestRng::new(42);
    let older = variant(1);
    let newer = variant(2);
    let mut base = SimFlash::new();
    save(&mut base, &older).unwrap(); // page A, seq 1
    save(&mut base, &newer).unwrap(); // page B, seq 2
    let (len, _) = payload_size(&newer);
    let record_len = HEADER_LEN + padded(len) + CRC_LEN;
    let mut detected = 0;
    for trial in 0..4000 {
        let mut f = base.clone();
        let page = if trial % 2 == 0 { Page::A } else { Page::B };
        let flips = 1 + rng.below(if trial % 3 == 0 { 64 } else { 3 });
        for _ in 0..flips {
            // Mostly inside the record, sometimes anywhere in the page.
            let byte =
                if rng.below(4) == 0 { rng.below(SIM_PAGE_SIZE) } else { rng.below(record_len) };
            f.page_mut(page)[byte] ^= 1 << rng.below(8);
        }
        // From the bytes that differ: two flips of one bit undo each other.
        let in_record = f.page(page)[..record_len] != base.page(page)[..record_len];
        let l = load(&f);
        let intact = f.page(page) == base.page(page);
        let expect = match (page, intact || !in_record) {
            (_, true) => newer,
            (Page::B, false) => older,
            (Page::A, false) => newer,
        };
        assert_eq!(l.settings, expect, "trial {trial}");
        if !intact && in_record {
            detected += 1;
        }
    }
    assert!(detected > 2000);
    // Both pages corrupted: defaults.
    let mut f = base.clone();
    f.page_mut(Page::A)[5] ^= 0x10;
    f.page_mut(Page::B)[HEADER_LEN + 7] ^= 0x01;
    let l = load(&f);
    assert_eq!((l.settings, l.source), (PipelineSettings::default(), Source::Defaults));
}

#[test]
fn sim_flash_behaves_like_nor_flash() {
    let mut f = SimFlash::new();
    f.program(Page::A, 0, 0x1234).unwrap();
    // Programming a programmed half-word is refused (STM32F1 PGERR), except with 0.
    assert_eq!(f.program(Page::A, 0, 0x0FFF), Err(FlashError::Program));
    f.program(Page::A, 0, 0).unwrap();
    assert_eq!(&f.page(Page::A)[..2], &[0, 0]);
    assert_eq!(f.program(Page::A, 1, 0), Err(FlashError::OutOfBounds));
    assert_eq!(f.program(Page::A, SIM_PAGE_SIZE, 0), Err(FlashError::OutOfBounds));
    let mut buf = [0u8; 4];
    assert_eq!(f.read(Page::B, SIM_PAGE_SIZE - 2, &mut buf), Err(FlashError::OutOfBounds));
    f.erase(Page::A).unwrap();
    assert!(f.page(Page::A).iter().all(|&b| b == 0xFF));
    f.cut_power_after(1, false);
    f.program(Page::B, 2, 0xABCD).unwrap();
    assert_eq!(f.program(Page::B, 4, 0x0000), Err(FlashError::PowerLoss));
    assert!(f.is_off());
    assert_eq!(f.erase(Page::B), Err(FlashError::PowerLoss));
    assert_eq!(&f.page(Page::B)[2..6], &[0xCD, 0xAB, 0xFF, 0xFF]);
    f.power_on();
    f.erase(Page::B).unwrap();
}

/// The power cut of `SimFlash` as its documentation has it: clean, the interrupted step and
/// every later one change nothing; torn, the interrupted erase leaves the first half of the
/// page erased and the rest as it was, the interrupted program writes the low byte only; the
/// steps after the cut change nothing either way. Steps count erases and programs, and the
/// last half-word of a page is programmable.
#[test]
fn sim_flash_power_cuts_are_clean_or_torn_as_documented() {
    let half = SIM_PAGE_SIZE / 2;
    let programmed = |f: &mut SimFlash| {
        for off in (0..SIM_PAGE_SIZE).step_by(2) {
            f.program(Page::A, off, 0x0F0F).unwrap();
        }
    };
    for torn in [false, true] {
        // An erase cut.
        let mut f = SimFlash::new();
        programmed(&mut f);
        assert_eq!(f.steps, SIM_PAGE_SIZE / 2);
        assert!(!f.is_off());
        f.cut_power_after(0, torn);
        assert_eq!(f.erase(Page::A), Err(FlashError::PowerLoss));
        assert!(f.is_off());
        let first = if torn { 0xFF } else { 0x0F };
        assert!(f.page(Page::A)[..half].iter().all(|&b| b == first), "torn {torn}");
        assert!(f.page(Page::A)[half..].iter().all(|&b| b == 0x0F), "torn {torn}");
        // Off: a second erase changes nothing, torn or not.
        let before = f.clone();
        assert_eq!(f.erase(Page::B), Err(FlashError::PowerLoss));
        assert_eq!(f.program(Page::B, 0, 0x1234), Err(FlashError::PowerLoss));
        assert_eq!(f, before);
        f.power_on();
        assert!(!f.is_off());
        f.erase(Page::A).unwrap();
        assert_eq!(f.steps, SIM_PAGE_SIZE / 2 + 1);
        // A program cut: the low byte only, when torn.
        f.program(Page::B, SIM_PAGE_SIZE - 2, 0xA55A).unwrap();
        assert_eq!(&f.page(Page::B)[SIM_PAGE_SIZE - 2..], &[0x5A, 0xA5]);
        f.cut_power_after(0, torn);
        assert_eq!(f.program(Page::B, 4, 0x1234), Err(FlashError::PowerLoss));
        let low = if torn { 0x34 } else { 0xFF };
        assert_eq!(&f.page(Page::B)[4..6], &[low, 0xFF], "torn {torn}");
        assert_eq!(f.program(Page::B, 8, 0x1234), Err(FlashError::PowerLoss));
        assert_eq!(&f.page(Page::B)[8..10], &[0xFF, 0xFF]);
    }
}

#[test]
fn registry_values_survive_a_save_exactly() {
    // Every setting at an extreme of its range, saved and loaded bit for bit.
    let mut s = PipelineSettings::default();
    for (i, e) in crate::registry::SETTINGS.iter().enumerate() {
        let v = match e.get(&s) {
            Value::F32(_) => Value::F32(
                (f64::from(if i % 2 == 0 { e.min } else { e.max }) / e.scale.factor()) as f32,
            ),
            other => other,
        };
        assert!(e.set(&mut s, v), "{}", e.name);
    }
    let mut f = SimFlash::new();
    save(&mut f, &s).unwrap();
    let l = load(&f);
    assert_eq!(l.settings, s);
    assert_eq!((l.skipped, l.missing), (0, 0));
    assert!(find("depth.density").is_some());
}

#[test]
#[ignore]
fn print_record_size() {
    let (len, _) = payload_size(&PipelineSettings::default());
    let mut probe = SimFlash::new();
    save(&mut probe, &PipelineSettings::default()).unwrap();
    println!("payload {len} record {} steps {}", HEADER_LEN + padded(len) + CRC_LEN, probe.steps);
}

/// The record's size with the current registry (`docs/commands.md` quotes it).
#[test]
fn record_size_of_the_current_registry() {
    let (len, count) = payload_size(&PipelineSettings::default());
    assert_eq!((count, len), (68, 493));
    assert_eq!(HEADER_LEN + padded(len) + CRC_LEN, 510);
}

/// The marine output settings (ids 114–119) are saved and loaded like the others.
#[test]
fn marine_output_settings_survive_a_save() {
    let mut s = PipelineSettings::default();
    s.sentences.talker = crate::registry::talker_code(*b"II");
    s.sentences.hdt = true;
    s.sentences.hdg = true;
    s.sentences.hdm = true;
    s.sentences.rot = true;
    s.sentences.xdr = true;
    s.sentences.prdid = false;
    let mut f = SimFlash::new();
    save(&mut f, &s).unwrap();
    let l = load(&f);
    assert_eq!(l.settings.sentences, s.sentences);
    assert_eq!((l.skipped, l.missing), (0, 0));
}

/// A record saved by the firmware before the marine sentences (ids 114–119): it loads in
/// full, `$PRDID` off as saved, the new settings at their defaults (counted as missing: the
/// output of a device in the field does not change with the update).
#[test]
fn a_record_from_before_the_marine_settings_loads_with_their_defaults() {
    const NEW: [u16; 6] = [114, 115, 116, 117, 118, 119];
    let mut old = PipelineSettings::default();
    old.sentences.prdid = false;
    old.output_rate_hz = 5;
    let f = record_without(&old, &NEW, Page::B, 3);
    let l = load(&f);
    assert_eq!(l.source, Source::Flash { page: Page::B, seq: 3 });
    assert_eq!((l.skipped, l.missing), (0, NEW.len() as u16));
    assert_eq!(l.settings, old);
    let s = l.settings.sentences;
    assert!(!s.prdid && s.pinah && !s.hdt && !s.hdg && !s.hdm && !s.rot && !s.xdr);
    assert_eq!(s.talker, crate::registry::talker_code(*b"HC"));
}

/// A record saved by the firmware before `adc.vrefint` and `i2c.clock` (ids 93 and 120; issue
/// #27): it loads in full, its own `adc.vref` kept, `adc.vrefint` at the datasheet's typical
/// 1.20 V (in the settings and in the gyro conversion's copy alike) and `i2c.clock` at ST's
/// 300 kHz, both counted as missing.
#[test]
fn a_record_from_before_adc_vrefint_and_i2c_clock_loads_with_their_defaults() {
    const NEW: [u16; 2] = [93, 120];
    let mut old = PipelineSettings::default();
    assert!(find("adc.vref").unwrap().set(&mut old, Value::F32(3.25)));
    old.depth.water_density_kg_m3 = 998.0;
    let f = record_without(&old, &NEW, Page::A, 12);
    let l = load(&f);
    assert_eq!(l.source, Source::Flash { page: Page::A, seq: 12 });
    assert_eq!((l.skipped, l.missing), (0, 2));
    assert_eq!(l.settings, old);
    assert_eq!((l.settings.adc.vrefint_v, l.settings.gyro.scale.vrefint_v), (1.20, 1.20));
    assert_eq!((l.settings.adc.vref_v, l.settings.gyro.scale.vref_v), (3.25, 3.25));
    assert_eq!(l.settings.i2c_clock_khz, 300);
    // A record with them keeps them.
    let mut new = old;
    assert!(find("adc.vrefint").unwrap().set(&mut new, Value::F32(1.234)));
    assert!(find("i2c.clock").unwrap().set(&mut new, Value::U16(100)));
    let mut f = SimFlash::new();
    save(&mut f, &new).unwrap();
    let l = load(&f);
    assert_eq!((l.skipped, l.missing), (0, 0));
    assert_eq!((l.settings.adc.vrefint_v, l.settings.gyro.scale.vrefint_v), (1.234, 1.234));
    assert_eq!(l.settings.i2c_clock_khz, 100);
}

/// A flash that records the order of its writes (issue #39, point 6): each erase and each
/// programmed half-word, with its page, offset and value.
struct Recording {
    inner: SimFlash,
    writes: Vec<(Page, Option<(usize, u16)>)>,
}

impl Flash for Recording {
    fn page_size(&self) -> usize {
        self.inner.page_size()
    }
    fn read(&self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        self.inner.read(page, offset, buf)
    }
    fn erase(&mut self, page: Page) -> Result<(), FlashError> {
        self.writes.push((page, None));
        self.inner.erase(page)
    }
    fn program(&mut self, page: Page, offset: usize, value: u16) -> Result<(), FlashError> {
        self.writes.push((page, Some((offset, value))));
        self.inner.program(page, offset, value)
    }
}

/// The save's order, which the power-cut tests cannot see (the CRC rejects a record whose
/// commit word came first and whose data a cut then left half written, so a save that wrote the
/// commit word first passed them all): the target page erased first, then every other
/// half-word of the record, the CRC's two last, and the commit word 0x5AA5 at offset 0 once,
/// after everything else, on the same page; nothing written to the other page (the previous
/// record stays valid until the new one is committed).
#[test]
fn a_save_erases_first_and_programs_the_commit_word_last() {
    let mut f = Recording { inner: SimFlash::new(), writes: Vec::new() };
    for round in 0..3u32 {
        f.writes.clear();
        let saved = save(&mut f, &variant(round)).expect("save");
        let w = &f.writes;
        assert!(w.iter().all(|(p, _)| *p == saved.page), "round {round}: the other page written");
        assert_eq!(w.first(), Some(&(saved.page, None)), "round {round}: not erased first");
        assert_eq!(w.iter().filter(|(_, x)| x.is_none()).count(), 1, "round {round}: erases");
        assert_eq!(w.last(), Some(&(saved.page, Some((0, COMMIT)))), "round {round}");
        let offsets: Vec<usize> = w[1..].iter().filter_map(|(_, x)| x.map(|(o, _)| o)).collect();
        assert_eq!(offsets.iter().filter(|&&o| o == 0).count(), 1, "round {round}: commit twice");
        // Every half-word from 2 up, once and in order; the CRC's two just before the commit.
        let n = offsets.len();
        assert!(offsets[..n - 1].windows(2).all(|p| p[1] == p[0] + 2), "round {round}");
        assert_eq!(offsets[0], 2, "round {round}");
        let header = valid_header(&f.inner, saved.page).expect("valid record");
        assert_eq!(header.seq, saved.seq);
    }
}
