//! Register-traffic and conversion tests against `embedded-hal-mock` transaction scripts. The
//! expected bytes are written out from the datasheet here, not computed with the driver's own
//! tables, so that a wrong table fails.

use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};

use super::*;

const ACC: u8 = 0x19;
const MAG: u8 = 0x1E;

/// Runs `f` on a driver whose bus expects exactly `script`, then checks that all of it ran.
fn with_script<T>(script: &[Transaction], f: impl FnOnce(&mut Lsm303dlh<Mock>) -> T) -> T {
    let mut dev = Lsm303dlh::new(Mock::new(script));
    let out = f(&mut dev);
    dev.destroy().done();
    out
}

fn assert_close(actual: [f32; 3], expected: [f32; 3]) {
    for (a, e) in actual.iter().zip(expected) {
        assert!((a - e).abs() <= 1e-5 * e.abs().max(1.0), "{actual:?} != {expected:?}");
    }
}

/// Little-endian, left-justified accelerometer bytes of 12-bit samples `x`, `y`, `z`.
fn accel_bytes(x: i16, y: i16, z: i16) -> Vec<u8> {
    [x, y, z].iter().flat_map(|v| (v << 4).to_le_bytes()).collect()
}

const ACCEL_READ: [u8; 1] = [0xA8];

#[test]
#[allow(clippy::unusual_byte_groupings)] // grouped as the fields PM2..0 | DR1..0 | Zen Yen Xen
fn init_accel_writes_ctrl1_and_ctrl4_for_every_rate_and_scale() {
    let rates = [
        (AccelRate::Hz50, 0b001_00_111),
        (AccelRate::Hz100, 0b001_01_111),
        (AccelRate::Hz400, 0b001_10_111),
        (AccelRate::Hz1000, 0b001_11_111),
    ];
    let scales = [(AccelScale::G2, 0x80), (AccelScale::G4, 0x90), (AccelScale::G8, 0xB0)];
    for (rate, ctrl1) in rates {
        for (scale, ctrl4) in scales {
            let script = [
                Transaction::write(ACC, vec![0x20, ctrl1]),
                Transaction::write(ACC, vec![0x23, ctrl4]),
            ];
            with_script(&script, |dev| {
                dev.init_accel(AccelConfig { rate, scale }).unwrap();
                assert_eq!(dev.accel_scale(), scale);
            });
        }
    }
}

#[test]
fn default_accel_config_is_100_hz_2_g() {
    let config = AccelConfig::default();
    assert_eq!(config, AccelConfig { rate: AccelRate::Hz100, scale: AccelScale::G2 });
    assert_eq!(config.rate.hz(), 100);
    assert_eq!(
        AccelConfig::new().with_rate(AccelRate::Hz400).with_scale(AccelScale::G8),
        AccelConfig { rate: AccelRate::Hz400, scale: AccelScale::G8 }
    );
    let script =
        [Transaction::write(ACC, vec![0x20, 0x2F]), Transaction::write(ACC, vec![0x23, 0x80])];
    with_script(&script, |dev| dev.init_accel(config).unwrap());
}

#[test]
fn init_mag_writes_cra_crb_and_continuous_mode_for_every_rate_and_gain() {
    let rates = [
        (MagRate::Hz0_75, 0x00),
        (MagRate::Hz1_5, 0x04),
        (MagRate::Hz3, 0x08),
        (MagRate::Hz7_5, 0x0C),
        (MagRate::Hz15, 0x10),
        (MagRate::Hz30, 0x14),
        (MagRate::Hz75, 0x18),
    ];
    let gains = [
        (MagGain::Gauss1_3, 0x20),
        (MagGain::Gauss1_9, 0x40),
        (MagGain::Gauss2_5, 0x60),
        (MagGain::Gauss4_0, 0x80),
        (MagGain::Gauss4_7, 0xA0),
        (MagGain::Gauss5_6, 0xC0),
        (MagGain::Gauss8_1, 0xE0),
    ];
    for (rate, cra) in rates {
        for (gain, crb) in gains {
            let script = [
                Transaction::write(MAG, vec![0x00, cra]),
                Transaction::write(MAG, vec![0x01, crb]),
                Transaction::write(MAG, vec![0x02, 0x00]),
            ];
            with_script(&script, |dev| {
                dev.init_mag(MagConfig { rate, gain }).unwrap();
                assert_eq!(dev.mag_gain(), gain);
            });
        }
    }
}

#[test]
fn default_mag_config_is_75_hz_1_9_gauss() {
    let config = MagConfig::default();
    assert_eq!(config, MagConfig { rate: MagRate::Hz75, gain: MagGain::Gauss1_9 });
    assert_eq!(config.rate.hz(), 75.0);
    assert_eq!(
        MagConfig::new().with_rate(MagRate::Hz15).with_gain(MagGain::Gauss8_1),
        MagConfig { rate: MagRate::Hz15, gain: MagGain::Gauss8_1 }
    );
    let script = [
        Transaction::write(MAG, vec![0x00, 0x18]),
        Transaction::write(MAG, vec![0x01, 0x40]),
        Transaction::write(MAG, vec![0x02, 0x00]),
    ];
    with_script(&script, |dev| dev.init_mag(config).unwrap());
}

#[test]
fn read_accel_raw_is_one_auto_increment_read_of_six_little_endian_bytes() {
    // +1 g on Z at ±2 g is 1000 LSB = 1000 << 4 = 0x3E80 in the registers.
    let script = [Transaction::write_read(
        ACC,
        ACCEL_READ.to_vec(),
        vec![0x80, 0xC1, 0xF0, 0xFF, 0x80, 0x3E],
    )];
    let raw = with_script(&script, |dev| dev.read_accel_raw().unwrap());
    assert_eq!(raw, [-1000, -1, 1000]);
}

#[test]
fn read_accel_raw_covers_the_12_bit_range_and_drops_the_low_nibble() {
    let mut bytes = accel_bytes(2047, -2048, 0);
    bytes[4] = 0x0F; // Z: bits below the 12-bit sample are ignored.
    let script = [Transaction::write_read(ACC, ACCEL_READ.to_vec(), bytes)];
    let raw = with_script(&script, |dev| dev.read_accel_raw().unwrap());
    assert_eq!(raw, [2047, -2048, 0]);
}

#[test]
fn read_accel_g_uses_each_scales_sensitivity() {
    // (scale, CTRL_REG4_A, raw per axis, expected g) with 1, 2 and 3.9 mg/LSB.
    let cases = [
        (AccelScale::G2, 0x80, [1000, -1000, 250], [1.0, -1.0, 0.25]),
        (AccelScale::G4, 0x90, [500, -500, 1000], [1.0, -1.0, 2.0]),
        (AccelScale::G8, 0xB0, [1000, -2000, 256], [3.9, -7.8, 0.9984]),
    ];
    for (scale, ctrl4, raw, g) in cases {
        let script = [
            Transaction::write(ACC, vec![0x20, 0x2F]),
            Transaction::write(ACC, vec![0x23, ctrl4]),
            Transaction::write_read(ACC, ACCEL_READ.to_vec(), accel_bytes(raw[0], raw[1], raw[2])),
        ];
        let out = with_script(&script, |dev| {
            dev.init_accel(AccelConfig::new().with_scale(scale)).unwrap();
            dev.read_accel_g().unwrap()
        });
        assert_close(out, g);
    }
}

#[test]
fn read_accel_g_before_init_assumes_the_reset_scale() {
    let script = [Transaction::write_read(ACC, ACCEL_READ.to_vec(), accel_bytes(0, 0, 1000))];
    let out = with_script(&script, |dev| dev.read_accel_g().unwrap());
    assert_eq!(out, [0.0, 0.0, 1.0]);
}

#[test]
fn accel_data_ready_reads_zyxda() {
    for (status, ready) in [(0x08, true), (0x0F, true), (0x07, false), (0xF7, false)] {
        let script = [Transaction::write_read(ACC, vec![0x27], vec![status])];
        assert_eq!(with_script(&script, |dev| dev.accel_data_ready().unwrap()), ready);
    }
}

#[test]
fn read_mag_raw_is_big_endian_in_x_y_z_order() {
    // X = 258, Y = -200, Z = 1000: the DLHC's X, Z, Y order would give [258, 1000, -200].
    let script =
        [Transaction::write_read(MAG, vec![0x03], vec![0x01, 0x02, 0xFF, 0x38, 0x03, 0xE8])];
    let raw = with_script(&script, |dev| dev.read_mag_raw().unwrap());
    assert_eq!(raw, [258, -200, 1000]);
}

#[test]
fn read_mag_ut_uses_separate_xy_and_z_sensitivities_for_every_gain() {
    // (gain, CRB_REG_M, LSB/gauss X and Y, LSB/gauss Z) from the DLH datasheet.
    let gains = [
        (MagGain::Gauss1_3, 0x20, 1055, 950),
        (MagGain::Gauss1_9, 0x40, 795, 710),
        (MagGain::Gauss2_5, 0x60, 635, 570),
        (MagGain::Gauss4_0, 0x80, 430, 385),
        (MagGain::Gauss4_7, 0xA0, 375, 335),
        (MagGain::Gauss5_6, 0xC0, 320, 285),
        (MagGain::Gauss8_1, 0xE0, 230, 205),
    ];
    for (gain, crb, xy, z) in gains {
        // One gauss (100 µT) on X, minus one on Y, one on Z; then half a gauss on each.
        let one = [xy, -xy, z].iter().flat_map(|v: &i16| v.to_be_bytes()).collect();
        let half = [xy / 2, -xy / 2, z / 2].iter().flat_map(|v: &i16| v.to_be_bytes()).collect();
        let script = [
            Transaction::write(MAG, vec![0x00, 0x18]),
            Transaction::write(MAG, vec![0x01, crb]),
            Transaction::write(MAG, vec![0x02, 0x00]),
            Transaction::write_read(MAG, vec![0x03], one),
            Transaction::write_read(MAG, vec![0x03], half),
        ];
        let (one, half) = with_script(&script, |dev| {
            dev.init_mag(MagConfig::new().with_gain(gain)).unwrap();
            (dev.read_mag_ut().unwrap(), dev.read_mag_ut().unwrap())
        });
        assert_close(one, [100.0, -100.0, 100.0]);
        let h = |lsb: i16, per_gauss: i16| f32::from(lsb / 2) * 100.0 / f32::from(per_gauss);
        assert_close(half, [h(xy, xy), -h(xy, xy), h(z, z)]);
    }
}

#[test]
fn read_mag_ut_before_init_assumes_the_reset_gain() {
    // Reset gain ±1.3 gauss: 1055 LSB/gauss on X/Y, 950 on Z; 211 LSB = 20 µT on X/Y.
    let script = [Transaction::write_read(
        MAG,
        vec![0x03],
        [211i16, -1055, 950].iter().flat_map(|v| v.to_be_bytes()).collect(),
    )];
    let out = with_script(&script, |dev| dev.read_mag_ut().unwrap());
    assert_close(out, [20.0, -100.0, 100.0]);
}

#[test]
fn mag_overflow_on_any_axis_is_an_error_but_raw_passes_it_through() {
    for axis in 0..3 {
        let mut bytes = vec![0x00, 0x10, 0x00, 0x20, 0x00, 0x30];
        bytes[2 * axis] = 0xF0;
        bytes[2 * axis + 1] = 0x00;
        let script = [
            Transaction::write_read(MAG, vec![0x03], bytes.clone()),
            Transaction::write_read(MAG, vec![0x03], bytes),
        ];
        let (ut, raw) = with_script(&script, |dev| (dev.read_mag_ut(), dev.read_mag_raw()));
        assert_eq!(ut, Err(Error::MagOverflow));
        assert_eq!(raw.unwrap()[axis], -4096);
    }
    // −4095 is a (large) valid reading, not an overflow.
    let script = [Transaction::write_read(MAG, vec![0x03], vec![0xF0, 0x01, 0, 0, 0, 0])];
    assert!(with_script(&script, |dev| dev.read_mag_ut()).is_ok());
}

#[test]
fn mag_data_ready_reads_drdy() {
    for (status, ready) in [(0x01, true), (0x03, true), (0x00, false), (0x02, false)] {
        let script = [Transaction::write_read(MAG, vec![0x09], vec![status])];
        assert_eq!(with_script(&script, |dev| dev.mag_data_ready().unwrap()), ready);
    }
}

#[test]
fn mag_id_reads_ira_irb_irc_and_accepts_h43() {
    let script = [
        Transaction::write_read(MAG, vec![0x0A], vec![0x48, 0x34, 0x33]),
        Transaction::write_read(MAG, vec![0x0A], vec![0x48, 0x34, 0x33]),
    ];
    with_script(&script, |dev| {
        assert_eq!(dev.mag_id().unwrap(), *b"H43");
        dev.check_mag_id().unwrap();
    });
}

#[test]
fn check_mag_id_rejects_anything_else() {
    for id in [[0x48, 0x34, 0x3C], [0x00; 3], [0xFF; 3]] {
        let script = [Transaction::write_read(MAG, vec![0x0A], id.to_vec())];
        assert_eq!(with_script(&script, |dev| dev.check_mag_id()), Err(Error::WrongId(id)));
    }
}

#[test]
fn i2c_errors_propagate_as_error_i2c() {
    let err = Err(Error::I2c(ErrorKind::Other));

    let script = [Transaction::write(ACC, vec![0x20, 0x2F]).with_error(ErrorKind::Other)];
    with_script(&script, |dev| assert_eq!(dev.init_accel(AccelConfig::new()), err));

    // A failed CTRL_REG4_A write leaves the conversion scale unchanged.
    let script = [
        Transaction::write(ACC, vec![0x20, 0x2F]),
        Transaction::write(ACC, vec![0x23, 0xB0]).with_error(ErrorKind::Other),
    ];
    with_script(&script, |dev| {
        assert_eq!(dev.init_accel(AccelConfig::new().with_scale(AccelScale::G8)), err);
        assert_eq!(dev.accel_scale(), AccelScale::G2);
    });

    let script = [
        Transaction::write(MAG, vec![0x00, 0x18]),
        Transaction::write(MAG, vec![0x01, 0x40]).with_error(ErrorKind::Other),
    ];
    with_script(&script, |dev| {
        assert_eq!(dev.init_mag(MagConfig::new()), err);
        assert_eq!(dev.mag_gain(), MagGain::Gauss1_3);
    });

    let script =
        [Transaction::write_read(ACC, ACCEL_READ.to_vec(), vec![0; 6])
            .with_error(ErrorKind::Other)];
    with_script(&script, |dev| assert_eq!(dev.read_accel_g(), Err(Error::I2c(ErrorKind::Other))));

    let script =
        [Transaction::write_read(MAG, vec![0x03], vec![0; 6]).with_error(ErrorKind::Other)];
    with_script(&script, |dev| assert_eq!(dev.read_mag_ut(), Err(Error::I2c(ErrorKind::Other))));

    let script = [Transaction::write_read(ACC, vec![0x27], vec![0]).with_error(ErrorKind::Other)];
    with_script(&script, |dev| assert_eq!(dev.accel_data_ready(), err.map(|()| false)));

    let script = [Transaction::write_read(MAG, vec![0x09], vec![0]).with_error(ErrorKind::Other)];
    with_script(&script, |dev| assert_eq!(dev.mag_data_ready(), err.map(|()| false)));

    let script =
        [Transaction::write_read(MAG, vec![0x0A], vec![0; 3]).with_error(ErrorKind::Other)];
    with_script(&script, |dev| assert_eq!(dev.check_mag_id(), err));
}

#[test]
fn errors_display() {
    let e: Error<ErrorKind> = Error::WrongId([0x48, 0x34, 0x3C]);
    assert_eq!(
        e.to_string(),
        "LSM303DLH magnetometer identification 0x48 0x34 0x3c, expected \"H43\""
    );
    assert_eq!(Error::<ErrorKind>::MagOverflow.to_string(), "LSM303DLH magnetometer overflow");
    assert_eq!(Error::I2c(ErrorKind::Other).to_string(), "LSM303DLH I2C error: Other");
}

#[test]
fn config_tables() {
    assert_eq!(
        [AccelScale::G2, AccelScale::G4, AccelScale::G8].map(AccelScale::mg_per_lsb),
        [1.0, 2.0, 3.9]
    );
    assert_eq!(
        [AccelRate::Hz50, AccelRate::Hz100, AccelRate::Hz400, AccelRate::Hz1000].map(AccelRate::hz),
        [50, 100, 400, 1000]
    );
    assert_eq!(MagGain::Gauss1_3.lsb_per_gauss_xy(), 1055);
    assert_eq!(MagGain::Gauss8_1.lsb_per_gauss_z(), 205);
    assert_eq!(MagRate::Hz0_75.hz(), 0.75);
}
