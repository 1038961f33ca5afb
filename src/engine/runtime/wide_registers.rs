//! Keeps a ball thread's AVX-512 registers in their initial state, so that its context switch
//! (a thousand of them a millisecond at 1,024 balls) does not save and restore them.
//!
//! The kernel saves a thread's vector registers at every switch with `XSAVES`, which skips the
//! register groups still in their initial state. Our code is built for plain x86-64 (SSE2) and
//! never touches the AVX-512 registers, but glibc's `memcpy`/`memmove`/`memset` pick their
//! AVX-512 variants on a machine that has it (they use `zmm16`–`zmm31`, which `vzeroupper` does
//! not clear), and a thread starts with a copy of its parent's registers: every ball thread is
//! born with the AVX-512 groups in use, and keeps them so, about 2 KB more to save and restore at
//! each switch. On the 1,024-ball gas that costs the balls a fifth of their updates
//! (docs/measurements.md, "The ball threads' AVX-512 registers").
//!
//! `XRSTOR` with those groups requested and marked absent in its header puts them back in their
//! initial state, which the processor then tracks as not in use. Those registers are
//! caller-saved in the System V ABI, and the `asm!` declares them clobbered (`clobber_abi`), so
//! a build that does keep values in them (`-C target-cpu=native`) saves them around it: clearing
//! them between cycles changes nothing the program computes. Measured on the 1,024-ball gas, 20
//! alternating runs of each build: a ball's updates a second +11 % (median of the pairs' ratios).

/// The `XSAVE` state components cleared: the AVX-512 opmask registers (5), the upper halves of
/// `zmm0`–`zmm15` (6) and `zmm16`–`zmm31` (7). Not AVX's upper halves (2), which glibc's AVX
/// variants clear themselves (`vzeroupper`): requesting component 1 or 2 would also load MXCSR
/// from the area, and a zero MXCSR unmasks every floating-point exception (SIGFPE at the next
/// inexact result).
#[cfg(target_arch = "x86_64")]
const WIDE: u64 = (1 << 5) | (1 << 6) | (1 << 7);

/// What a thread may do about its wide registers on this machine (on other architectures than
/// x86-64: nothing).
#[derive(Clone, Copy, Debug)]
pub struct WideRegisters {
    /// `XGETBV` with `ECX = 1` (the state components in use) is available: check before clearing.
    #[cfg(target_arch = "x86_64")]
    in_use_known: bool,
    /// The processor and the kernel support AVX-512 and `XSAVE`: there is something to clear.
    #[cfg(target_arch = "x86_64")]
    present: bool,
}

impl WideRegisters {
    /// What this machine supports (a few `CPUID`s: call once per thread, not per cycle).
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            // `is_x86_feature_detected!` checks the operating system's support too (`XCR0`):
            // with AVX-512 reported, the kernel saves and restores those registers.
            let present = std::is_x86_feature_detected!("xsave") && std::is_x86_feature_detected!("avx512f");
            // CPUID leaf 0xD, sub-leaf 1, EAX bit 2: `XGETBV` with `ECX = 1` is supported (leaf
            // 0xD exists wherever XSAVE does, checked first).
            let in_use_known = present && std::arch::x86_64::__cpuid_count(0xD, 1).eax & (1 << 2) != 0;
            WideRegisters { in_use_known, present }
        }
        #[cfg(not(target_arch = "x86_64"))]
        WideRegisters {}
    }

    /// Puts the wide registers back in their initial state if they are in use (a few cycles when
    /// they are not: one `XGETBV`).
    #[inline]
    pub fn release(self) {
        #[cfg(target_arch = "x86_64")]
        {
            if !self.present {
                return;
            }
            if self.in_use_known && in_use() & WIDE == 0 {
                return;
            }
            clear();
        }
    }
}

/// The `XSAVE` state components in use now (`XINUSE` masked by `XCR0`).
#[cfg(target_arch = "x86_64")]
#[inline]
fn in_use() -> u64 {
    let (lo, hi): (u32, u32);
    // SAFETY: `XGETBV` with `ECX = 1` is supported (`WideRegisters::detect` checked CPUID); it
    // only reads into EAX and EDX, touches no memory and no flags.
    unsafe {
        std::arch::asm!("xgetbv", in("ecx") 1u32, out("eax") lo, out("edx") hi,
            options(nomem, nostack, preserves_flags));
    }
    (u64::from(hi) << 32) | u64::from(lo)
}

/// Initialises the [`WIDE`] state components with `XRSTOR` from an area whose header marks them
/// absent.
#[cfg(target_arch = "x86_64")]
#[cold]
#[inline(never)]
fn clear() {
    /// A standard-format `XSAVE` area: the legacy region (512 bytes, not read: components 0 and
    /// 1 are not requested, nor MXCSR with them) and the header (64 bytes), all zero, 64-byte aligned as `XRSTOR`
    /// requires. `XSTATE_BV = 0` says every requested component is absent, so each is set to its
    /// initial state; `XCOMP_BV = 0` is the standard format; the reserved bytes are zero.
    #[repr(C, align(64))]
    struct Area([u8; 576]);
    static AREA: Area = Area([0; 576]);
    let mask = WIDE;
    // SAFETY: XSAVE is supported and enabled by the OS (`detect`), so XRSTOR runs in user mode;
    // the area is valid, aligned and well-formed (see `Area`) and only read. The instruction
    // writes only the requested components' registers (the upper halves of zmm0–15, zmm16–31,
    // k0–7), all caller-saved under the C ABI, which `clobber_abi` declares clobbered; it leaves x87, SSE, AVX and MXCSR alone
    // (components 0, 1 and 2 are not requested) and no flags change.
    unsafe {
        std::arch::asm!("xrstor64 [{area}]", area = in(reg) &AREA,
            in("eax") mask as u32, in("edx") (mask >> 32) as u32,
            clobber_abi("C"), options(nostack, preserves_flags, readonly));
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// MXCSR, the SSE control and status register.
    fn mxcsr() -> u32 {
        let mut csr = 0u32;
        // SAFETY: STMXCSR writes the 4 bytes of `csr`, a valid, aligned local.
        unsafe { std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack, preserves_flags)) };
        csr
    }

    #[test]
    fn release_puts_the_avx512_registers_back_in_their_initial_state_and_leaves_sse_alone() {
        let wide = WideRegisters::detect();
        if !(wide.present && wide.in_use_known) {
            eprintln!("this machine has no AVX-512 (or cannot tell its registers' use): nothing to clear");
            wide.release();
            return;
        }
        // SAFETY: AVX-512F is present and enabled (`detect`). The instruction writes only zmm16
        // (all ones), which no code of this test keeps a value in and which is caller-saved.
        unsafe { std::arch::asm!("vpternlogd zmm16, zmm16, zmm16, 0xff", options(nomem, nostack, preserves_flags)) };
        assert_ne!(in_use() & WIDE, 0, "zmm16 written: AVX-512 state in use");
        // The division first: it raises MXCSR's sticky inexact flag, which release must keep.
        let x = std::hint::black_box(1.0f64) / 3.0;
        let csr = mxcsr();
        wide.release();
        assert_eq!(in_use() & WIDE, 0, "released: no AVX-512 state in use");
        assert_eq!(mxcsr(), csr, "MXCSR unchanged");
        assert_eq!(std::hint::black_box(1.0f64) / 3.0, x);
        // Nothing to clear: the check alone.
        wide.release();
        assert_eq!(in_use() & WIDE, 0);
    }
}
