//! Replies about the board itself: the self-test (`SELFTEST`) and the fault record found at
//! boot (`$PINAR,OK,FAULT,...`, sent once, unasked).

use super::reply::Out;
use crate::nmea::Sentence;
use crate::supervision::fault_record::{FaultKind, FaultRegs};
use crate::supervision::selftest::{self, Inputs};

/// Volts (or g, µT) × 1000, rounded; negative and NaN give 0.
fn milli(v: f32) -> u64 {
    (v * 1000.0 + 0.5) as u64
}

fn norm(v: [f32; 3]) -> f32 {
    ekf_core::mathf::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
}

/// `$PINAR,OK,SELFTEST,<overall>,<grades>,<HSE kHz>,<VDDA mV>,<accel mg>,<mag µT>,
/// <XY ref mV>,<Z ref mV>,<depth mV>,<I²C errors>,<bus clears>*hh` (docs/commands.md; an
/// empty field: not measured).
pub fn selftest_reply(verb: &'static str, inputs: &Inputs) -> Out {
    let report = selftest::evaluate(inputs);
    let mut out = Out::ok(verb);
    out.field(report.overall().name());
    out.hex(report.code(), 5);
    let opt = |out: &mut Out, v: Option<u64>| match v {
        Some(v) => out.uint(v),
        None => out.field(""),
    };
    opt(&mut out, inputs.hse.and_then(|h| h.measured_hz()).map(|hz| u64::from(hz / 1000)));
    opt(&mut out, inputs.vdda_v.map(milli));
    opt(&mut out, inputs.accel_g.map(|a| milli(norm(a))));
    opt(&mut out, inputs.mag_ut.map(|m| (norm(m) + 0.5) as u64));
    opt(&mut out, inputs.xy_ref_v.map(milli));
    opt(&mut out, inputs.z_ref_v.map(milli));
    opt(&mut out, inputs.depth_v.map(|(v, _)| milli(v)));
    out.uint(u64::from(inputs.i2c_errors.min(99_999)));
    out.uint(u64::from(inputs.bus_clears.min(999)));
    out
}

/// `$PINAR,OK,FAULT,<HARDFAULT|PANIC>,<PC>,<LR>,<CFSR>,<HFSR>,<address or line>*hh`: the
/// record the previous run left (hex words; the last field is BFAR or MMFAR when CFSR marks
/// it valid, empty otherwise; for a panic, the source line in decimal).
pub fn fault_reply(kind: FaultKind, regs: &FaultRegs) -> Sentence {
    let mut out = Out::ok("FAULT");
    out.field(kind.name());
    out.hex(regs.pc, 8);
    out.hex(regs.lr, 8);
    out.hex(regs.cfsr, 8);
    out.hex(regs.hfsr, 8);
    match kind {
        FaultKind::Panic => out.uint(u64::from(regs.line)),
        FaultKind::HardFault if regs.cfsr & (1 << 15) != 0 => out.hex(regs.bfar, 8),
        FaultKind::HardFault if regs.cfsr & (1 << 7) != 0 => out.hex(regs.mmfar, 8),
        FaultKind::HardFault => out.field(""),
    }
    out.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::verify;
    use crate::supervision::clock_check::HseCheck;
    use crate::supervision::i2c_bus::Clear;

    fn text(s: &Sentence) -> &str {
        core::str::from_utf8(s.as_bytes()).unwrap()
    }

    #[test]
    fn the_selftest_reply_of_a_full_report_fits_one_sentence() {
        let inputs = Inputs {
            hse: Some(HseCheck::WrongFrequency(12_003_000)),
            vdda_v: Some(3.301),
            ranks_aligned: true,
            accel_g: Some([0.0, 0.6, 0.8]),
            mag_id_ok: Some(true),
            mag_ut: Some([30.0, 0.0, -40.0]),
            xy_ref_v: Some(1.2304),
            z_ref_v: Some(1.5),
            depth_v: Some((3.2999, true)),
            depth_connected: Some(true),
            i2c_errors: 1_000_000,
            bus_clears: 12_345,
            last_clear: Some(Clear::Freed { clocks: 9 }),
            settings_from_flash: false,
            fault: Some(FaultKind::Panic),
        };
        let s = selftest_reply("SELFTEST", &inputs).finish();
        let t = text(&s);
        assert!(verify(t.trim_end().as_bytes()).is_ok(), "{t}");
        let body = t.split('*').next().unwrap();
        // clock fail (2), settings warn (1) at bits 16, depth warn at bits 12, I2C warn at 14,
        // fault warn at 18.
        assert_eq!(
            body, "$PINAR,OK,SELFTEST,FAIL,55002,12003,3301,1000,50,1230,1500,3300,99999,999",
            "{t}"
        );
        assert!(t.len() <= 82, "{} characters", t.len());
    }

    /// The report a first flash gives on a working board (docs/bring-up.md, step 4): no
    /// settings record in flash yet, so the settings item (bits 16–17) warns (1); with no depth
    /// sensor the boot's probe finds PA1 floating and the depth item (bits 12–13) is "not
    /// connected" (3), whatever the floating pin reads (about 1.2 V, issue #27 point 4): the
    /// report is `WARN,13000`. With a sensor: `WARN,10000`, and `WARN,11000` when its output
    /// is at a rail; after a `SAVE`, `PASS,00000`.
    #[test]
    fn a_first_flash_warns_for_the_settings() {
        let first = Inputs {
            hse: Some(HseCheck::Ok(8_000_000)),
            vdda_v: Some(3.3),
            ranks_aligned: true,
            accel_g: Some([0.0, 0.0, 1.0]),
            mag_id_ok: Some(true),
            mag_ut: Some([20.0, 0.0, 40.0]),
            xy_ref_v: Some(1.23),
            z_ref_v: Some(1.5),
            depth_v: Some((1.2, false)),
            depth_connected: Some(false),
            i2c_errors: 0,
            bus_clears: 1,
            last_clear: Some(Clear::Freed { clocks: 0 }),
            settings_from_flash: false,
            fault: None,
        };
        let s = selftest_reply("SELFTEST", &first).finish();
        let body = text(&s).split('*').next().unwrap().to_owned();
        assert_eq!(body, "$PINAR,OK,SELFTEST,WARN,13000,8000,3300,1000,45,1230,1500,1200,0,1");
        let sensor = Inputs { depth_connected: Some(true), ..first };
        let s = selftest_reply("SELFTEST", &sensor).finish();
        assert!(text(&s).starts_with("$PINAR,OK,SELFTEST,WARN,10000,"), "{}", text(&s));
        let at_rail = Inputs { depth_v: Some((3.3, true)), ..sensor };
        let s = selftest_reply("SELFTEST", &at_rail).finish();
        assert!(text(&s).starts_with("$PINAR,OK,SELFTEST,WARN,11000,"), "{}", text(&s));
        let saved = Inputs { settings_from_flash: true, ..sensor };
        let s = selftest_reply("SELFTEST", &saved).finish();
        assert!(text(&s).starts_with("$PINAR,OK,SELFTEST,PASS,00000,"), "{}", text(&s));
        let saved_no_sensor = Inputs { settings_from_flash: true, ..first };
        let s = selftest_reply("SELFTEST", &saved_no_sensor).finish();
        assert!(text(&s).starts_with("$PINAR,OK,SELFTEST,WARN,03000,"), "{}", text(&s));
    }

    #[test]
    fn nothing_measured_leaves_fields_empty() {
        let s = selftest_reply("SELFTEST", &Inputs::default()).finish();
        assert!(text(&s).starts_with("$PINAR,OK,SELFTEST,FAIL,"), "{}", text(&s));
        assert!(text(&s).contains(",,,,,,,0,0*"), "{}", text(&s));
    }

    #[test]
    fn the_fault_reply_names_the_valid_address() {
        let regs = FaultRegs {
            pc: 0x0800_1234,
            lr: 0x0800_0F01,
            cfsr: 1 << 9 | 1 << 15,
            hfsr: 1 << 30,
            mmfar: 0x1111_1111,
            bfar: 0x4000_5800,
            line: 0,
        };
        let s = fault_reply(FaultKind::HardFault, &regs);
        assert!(
            text(&s).starts_with(
                "$PINAR,OK,FAULT,HARDFAULT,08001234,08000F01,00008200,40000000,40005800*"
            ),
            "{}",
            text(&s)
        );
        let s = fault_reply(FaultKind::Panic, &FaultRegs { line: 214, ..FaultRegs::default() });
        assert!(
            text(&s).starts_with("$PINAR,OK,FAULT,PANIC,00000000,00000000,00000000,00000000,214*")
        );
        let s = fault_reply(FaultKind::HardFault, &FaultRegs { cfsr: 1 << 17, ..regs });
        assert!(text(&s).contains(",00020000,40000000,*"), "{}", text(&s));
        // MMARVALID (CFSR bit 7, with DACCVIOL bit 1): the MemManage address.
        let s = fault_reply(FaultKind::HardFault, &FaultRegs { cfsr: 1 << 1 | 1 << 7, ..regs });
        assert!(text(&s).contains(",00000082,40000000,11111111*"), "{}", text(&s));
    }
}
