//! The smallest program that runs the `Ekf`: one full update per loop on opaque inputs. Built
//! for thumbv7m-none-eabi it measures the flash the estimator costs, and with the
//! `panic-proof` feature its link fails if any panic is reachable from `Ekf::update`.
//! (On the host it only type-checks the same code.)
#![cfg_attr(target_os = "none", no_std, no_main)]

use core::hint::black_box;

// The package's library carries build.rs's native link of libgcc's soft-float (cargo passes
// `-l` to a package's library only): linked like the firmware's. Its code is not used here.
use ekf_emu as _;

use ekf_core::{settings::Settings, AttitudeFilter, Ekf, ImuSample, Vec3};

fn step(ekf: &mut Ekf) {
    let s =
        black_box(ImuSample::new(0.02, Vec3::new(0.01, -0.02, 0.003), Vec3::new(0.1, -0.2, -9.8)));
    black_box(ekf.update(&s));
    black_box(ekf.attitude());
}

#[cfg(not(target_os = "none"))]
fn main() {
    let mut ekf = Ekf::new(Settings::default());
    for _ in 0..1000 {
        step(&mut ekf);
    }
}

#[cfg(target_os = "none")]
mod target {
    #[cortex_m_rt::entry]
    fn main() -> ! {
        let mut ekf = super::Ekf::new(super::Settings::default());
        loop {
            super::step(&mut ekf);
        }
    }

    #[cfg(not(feature = "panic-proof"))]
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        cortex_m::asm::udf()
    }

    #[cfg(feature = "panic-proof")]
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        extern "C" {
            /// Deliberately undefined: referencing it makes the link fail.
            fn ekf_update_path_contains_a_reachable_panic() -> !;
        }
        // SAFETY: never executed; the link fails if this handler is reachable at all.
        unsafe { ekf_update_path_contains_a_reachable_panic() }
    }
}
