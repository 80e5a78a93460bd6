//! The hot loop, compiled for the CPU it runs on.
//!
//! A release build targets any x86-64 CPU (SSE2), so that the binary runs everywhere. The
//! rigid-body RK4 step ([`crate::vehicle::X3d::step`], a third of the 200 Hz loop) is compiled a
//! second time for AVX2 and picked at run time (`avx2_dispatch!`): the VEX three-operand
//! instructions drop most register copies and the 17-element stage sums use 256-bit vectors
//! (−17 % instructions in that step). The results are the same bits, because the arithmetic is
//! the same IEEE operations in the same order (Rust never contracts a·b + c into an FMA, and never
//! reorders a floating-point sum). The mocap capture, the station and the engine's per-tick step
//! came out slower compiled this way (their time is in callees that are not inlined), so they are
//! not.

use std::sync::atomic::{AtomicBool, Ordering};

static BASELINE_ONLY: AtomicBool = AtomicBool::new(false);

/// Runs the any-CPU code even where AVX2 is present, from now on, in every thread. The results
/// are the same bits either way (the acceptance tests check exactly that with this switch).
pub fn set_baseline_only(on: bool) {
    BASELINE_ONLY.store(on, Ordering::Relaxed);
}

/// True when this CPU has AVX2 (std caches the answer after the first query) and
/// [`set_baseline_only`] is off.
#[inline(always)]
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        !BASELINE_ONLY.load(Ordering::Relaxed) && std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Declares `fn name(&mut self, args) -> R` that runs `any_cpu(args)` compiled for AVX2 when the
/// CPU has it (through `avx2`, generated here), and as compiled for any CPU otherwise. The body,
/// `fn any_cpu`, is written by hand and must be `#[inline(always)]` so that it is compiled into
/// both.
macro_rules! avx2_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident => $avx2:ident, $any:ident (&mut self $(, $arg:ident : $ty:ty)*) $(-> $ret:ty)?) => {
        $(#[$meta])*
        $vis fn $name(&mut self $(, $arg: $ty)*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            if $crate::cpu::has_avx2() {
                // SAFETY: the CPU has AVX2, checked just above
                return unsafe { self.$avx2($($arg),*) };
            }
            self.$any($($arg),*)
        }

        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        unsafe fn $avx2(&mut self $(, $arg: $ty)*) $(-> $ret)? {
            self.$any($($arg),*)
        }
    };
}
pub(crate) use avx2_dispatch;
