//! has-dsp's fixed-point back-projection as firmware links it, for its flash and stack size.
//!
//! A static library exporting one C function, [`has_bp_q15_image`]: one snapshot of Q15 range
//! profiles (an 8 × 8 receive subarray, 512 bins each) back-projected into a 16 × 16 × 8 grid of
//! `i64` accumulators (0.25 m voxels), the configuration and inputs checked, the image written
//! as `f32`. Everything is caller-owned or static: no allocation, no `std`
//! on the target. Flash used by it (link-time optimised, so only what the function reaches):
//!
//! ```sh
//! CARGO_PROFILE_RELEASE_LTO=true CARGO_PROFILE_RELEASE_OPT_LEVEL=s CARGO_PROFILE_RELEASE_DEBUG=0 \
//!   cargo build -p has-dsp --example bp_firmware --release --target thumbv7em-none-eabihf
//! llvm-size target/thumbv7em-none-eabihf/release/examples/libbp_firmware.a
//! ```
//!
//! On the host (`cargo build --examples`) the same file is an ordinary static library with `std`.
#![cfg_attr(target_os = "none", no_std)]

use has_dsp::bp::{AccQ15, Backprojector, BpConfig, Interp, PhaseEval, Snapshot, VoxelGrid};
use has_dsp::fixed::CQ15;
use num_complex::Complex;

/// Voxels of the tile: 16 × 16 × 8.
pub const VOXELS: usize = 16 * 16 * 8;
/// Receive elements per snapshot (an 8 × 8 subarray).
pub const ELEMENTS: usize = 64;
/// Bins per range profile.
pub const BINS: usize = 512;

/// Images one snapshot into `image` (`f32`, value units of the profiles), with `acc` as the
/// `i64` accumulator scratch. `tx` and `rx` are grid-local metres, `profiles` element-major Q15
/// with one block exponent per element. Returns 0 on success, 1 on any error (bad geometry, an
/// exponent out of range).
#[allow(unsafe_code)] // `no_mangle`: the symbol firmware links against.
#[no_mangle]
pub extern "C" fn has_bp_q15_image(
    tx: &[f32; 3],
    rx: &[[f32; 3]; ELEMENTS],
    profiles: &[CQ15; ELEMENTS * BINS],
    exponents: &[i32; ELEMENTS],
    acc: &mut [Complex<i64>; VOXELS],
    image: &mut [Complex<f32>; VOXELS],
) -> i32 {
    let mut run = || -> Result<(), has_dsp::DspError> {
        let bp = Backprojector::new(BpConfig {
            grid: VoxelGrid {
                origin: glam::Vec3::ZERO,
                spacing: glam::Vec3::splat(0.25),
                dims: [16, 16, 8],
            },
            wavelength_m: 0.029_979_246,
            r0_m: 0.0,
            dr_m: 0.374_740_6,
            interp: Interp::Linear,
            phase: PhaseEval::Poly,
        })?;
        let rx: [glam::Vec3; ELEMENTS] = core::array::from_fn(|i| glam::Vec3::from_array(rx[i]));
        let mut state = AccQ15::new(&bp, &mut acc[..])?;
        bp.push_snapshot_q15(
            &mut state,
            &Snapshot {
                tx: glam::Vec3::from_array(*tx),
                rx: &rx,
                profiles,
                profile_len: BINS,
            },
            exponents,
        )?;
        state.to_image_f32(&mut image[..])
    };
    match run() {
        Ok(()) => 0,
        Err(_) => 1,
    }
}

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {}
}
