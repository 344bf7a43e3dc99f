//! `ekf-emu`: the firmware's pipeline over an embedded trace, printing its NMEA sentences — on
//! the host to stdout, on a Cortex-M3 (QEMU netduino2, the firmware's memory map) through
//! semihosting. `scripts/run-emulated --check` compares the two byte for byte.
#![cfg_attr(target_os = "none", no_std, no_main)]

mod run;

#[cfg(not(target_os = "none"))]
fn main() {
    use std::io::Write as _;
    let mut s = String::new();
    if run::run(&mut s).is_err() {
        eprintln!("ekf-emu: formatting failed");
        std::process::exit(1);
    }
    if std::io::stdout().write_all(s.as_bytes()).is_err() {
        std::process::exit(1);
    }
}

#[cfg(target_os = "none")]
mod target {
    use core::fmt::Write;
    use cortex_m_rt::entry;
    use cortex_m_semihosting::{debug, hio};

    /// Semihosting stdout, buffered by line so QEMU sees few traps.
    struct Out {
        host: hio::HostStream,
        buf: [u8; 256],
        len: usize,
    }

    impl Out {
        fn flush(&mut self) -> core::fmt::Result {
            let r = self.host.write_all(&self.buf[..self.len]).map_err(|_| core::fmt::Error);
            self.len = 0;
            r
        }
    }

    impl Write for Out {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            for &b in s.as_bytes() {
                if self.len == self.buf.len() {
                    self.flush()?;
                }
                self.buf[self.len] = b;
                self.len += 1;
                if b == b'\n' {
                    self.flush()?;
                }
            }
            Ok(())
        }
    }

    #[entry]
    fn main() -> ! {
        let code = match hio::hstdout() {
            Ok(host) => {
                let mut out = Out { host, buf: [0; 256], len: 0 };
                match super::run::run(&mut out).and_then(|_| out.flush()) {
                    Ok(()) => debug::EXIT_SUCCESS,
                    Err(_) => debug::EXIT_FAILURE,
                }
            }
            Err(_) => debug::EXIT_FAILURE,
        };
        debug::exit(code);
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// A panic ends the emulation with a failure code (the host-side check then fails too).
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
