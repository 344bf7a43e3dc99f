//! `$PINAB`, the boot sentence: sent once when the firmware starts, before any other output.

use super::{NmeaError, Sentence};
use crate::supervision::reset_cause::ResetCause;

/// `$PINAB,<clock>,<reset cause>,<imu>,<version>[,<settings>]*hh`: `clock` `HSE72` | `HSI64`
/// (the application's clock source); reset cause `POR` `PIN` `SFT` `IWDG` `WWDG` `LPWR` `UNK`
/// ([`ResetCause::tag`]); imu `OK` | `FAIL` (LSM303DLH configured or not); `version` the
/// firmware's; `settings` (when the firmware loads its settings from flash) `A` | `B` (the
/// page they came from) | `DEFAULTS` (no valid record).
pub fn pinab(
    clock: &str,
    reset: ResetCause,
    imu_ok: bool,
    version: &str,
    settings: Option<&str>,
) -> Result<Sentence, NmeaError> {
    let mut s = Sentence::new();
    let imu = if imu_ok { "OK" } else { "FAIL" };
    for field in ["PINAB,", clock, ",", reset.tag(), ",", imu, ",", version] {
        s.push_str(field)?;
    }
    if let Some(settings) = settings {
        s.push_str(",")?;
        s.push_str(settings)?;
    }
    s.finish()?;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::verify;
    use crate::supervision::reset_cause::{IWDGRSTF, PINRSTF, PORRSTF};

    #[test]
    fn the_reset_cause_is_reported_at_boot() {
        let iwdg = ResetCause::from_csr(IWDGRSTF | PINRSTF);
        let s = pinab("HSE72", iwdg, true, "0.1.0", Some("A")).unwrap();
        assert_eq!(s.as_str(), "$PINAB,HSE72,IWDG,OK,0.1.0,A*4A\r\n");
        assert_eq!(verify(s.as_bytes()).unwrap(), "PINAB,HSE72,IWDG,OK,0.1.0,A");
        let por = ResetCause::from_csr(PORRSTF | PINRSTF);
        let s = pinab("HSI64", por, false, "0.1.0", None).unwrap();
        assert_eq!(verify(s.as_bytes()).unwrap(), "PINAB,HSI64,POR,FAIL,0.1.0");
        let s = pinab("HSE72", ResetCause::Pin, true, "0.1.0", Some("DEFAULTS")).unwrap();
        assert_eq!(verify(s.as_bytes()).unwrap(), "PINAB,HSE72,PIN,OK,0.1.0,DEFAULTS");
    }
}
