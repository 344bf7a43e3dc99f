"""Cortex-M3 (STM32F103) cycle model over Unicorn emulation of a thumbv7m ELF.

The emulator (Unicorn, QEMU's ARM core, Cortex-M3 model) executes the real binary; a
basic-block hook records the exact sequence of executed straight-line blocks. Every block is
decoded once (Capstone) and priced with the model below; operand-dependent instructions
(long multiplies, divides) are priced per execution from their register values by a hook on
their address; data reads from flash are counted by a memory hook on the flash range.

Model (documented in docs/performance.md, "The cycle model"):

Core (Cortex-M3 TRM r2p1, table 18-1 "Cortex-M3 instruction set summary"), P = 2:
  data processing, MOV/MOVW/MOVT, shifts, extends, bit-field, CLZ, compare, IT, NOP   1
  ... writing the PC                                                                1 + P
  MUL/MULS 1; MLA, MLS 2
  UMULL/SMULL 3 + (operands with |x| >= 2^16)   (3-5, early termination)
  UMLAL/SMLAL 4 + (0, 2, 3 for 0, 1, 2 such operands)   (4-7)
  UDIV/SDIV   min(12, 2 + ceil(q/3)), q = max(0, clz(|divisor|) - clz(|dividend|) + 1)
                                                 (2-12; a linear interpolation of the bounds)
  LDR/LDRB/LDRH/LDRSB/LDRSH/LDREX, STR/STRB/STRH/STREX  2, but 1 right after a single LDR
      whose loaded register is not this one's address register ("neighbouring load/store
      pipelining"; nothing pipelines after a store)
  LDR to PC 2 + P;  LDRD/STRD 1 + 2;  LDM/STM/PUSH/POP 1 + N (+ P with the PC)
  B/BL/BX/BLX taken 1 + P; conditional B and CBZ/CBNZ not taken 1; TBB/TBH 2 + P
  Instructions of an IT block whose condition fails are priced as if executed (<= 1-2 cycles
  of overestimate each).

Flash (STM32F1 at 72 MHz, W wait states, prefetch buffer on: two 64-bit lines, the one being
executed and the next one, fetched sequentially, each line read taking 1 + W cycles):
  (a) a taken branch whose target is neither in the branch's own line nor the next one:
      + W (refill from flash); the return to the caller of a measured function always counts;
  (b) sequential fetch bandwidth: a straight-line block crossing k line boundaries cannot run
      faster than k (1 + W) cycles: + max(0, k (1 + W) - core cycles of the block);
  (c) every data read from flash (literal pools, .rodata, the trace): + W.
  At W = 0 all three terms vanish and the model is the core model.
"""

from __future__ import annotations

import bisect
import math
import re
import struct
from dataclasses import dataclass, field

import capstone
from capstone import arm_const as C
from elftools.elf.elffile import ELFFile
import unicorn
from unicorn import arm_const as A

FLASH_BASE, FLASH_SIZE = 0x0800_0000, 512 * 1024
RAM_BASE, RAM_SIZE = 0x2000_0000, 64 * 1024
LINE = 8  # STM32F1 flash line (prefetch block), bytes
P = 2  # pipeline refill of a taken branch, cycles
RETURN_ADDR = FLASH_BASE + FLASH_SIZE - 0x100  # never executed: emulation stops there
PAINT = 0xC5C5C5C5

_INS = {getattr(C, n): n[len("ARM_INS_"):].lower() for n in dir(C) if n.startswith("ARM_INS_")}

DATA_1 = {
    "adc", "add", "addw", "adr", "and", "asr", "bfc", "bfi", "bic", "clz", "cmn", "cmp", "eor",
    "lsl", "lsr", "mov", "movw", "movt", "mvn", "orn", "orr", "rbit", "rev", "rev16", "revsh",
    "ror", "rrx", "rsb", "sbc", "sbfx", "ssat", "sub", "subw", "sxtb", "sxth", "teq", "tst",
    "ubfx", "usat", "uxtb", "uxth", "it", "nop", "mul", "neg", "cpsid", "cpsie", "mrs", "msr",
    "sev", "wfi", "wfe", "yield", "bkpt", "dmb", "dsb", "isb", "clrex", "pld", "svc", "udf",
}
LOAD1 = {"ldr", "ldrb", "ldrh", "ldrsb", "ldrsh", "ldrex", "ldrexb", "ldrexh", "ldrt", "ldrbt",
         "ldrht", "ldrsbt", "ldrsht"}
STORE1 = {"str", "strb", "strh", "strex", "strexb", "strexh", "strt", "strbt", "strht"}
MULTI = {"ldm", "ldmdb", "stm", "stmdb", "push", "pop", "ldrd", "strd"}
BRANCH = {"b", "bl", "bx", "blx", "cbz", "cbnz", "tbb", "tbh"}
MULL = {"umull", "smull"}
MLAL = {"umlal", "smlal"}
DIV = {"udiv", "sdiv"}


@dataclass
class Insn:
    addr: int
    size: int
    name: str
    text: str
    cost: int  # core cycles when executed (taken, for branches); dynamic ones: 0 here
    nt_cost: int  # core cycles if it is the block's last instruction and falls through
    dynamic: str | None = None  # "mull", "mlal", "div": priced per execution
    dyn_regs: tuple = ()
    cond: bool = False  # conditional (in an IT block, or a conditional branch)


@dataclass
class Block:
    addr: int
    size: int
    insns: list
    core_taken: int  # static core cycles when the last instruction transfers control
    core_fall: int  # ... when execution falls through to addr + size
    crossings: int  # 8-byte line boundaries inside the block
    last_line: int
    fkey: str = ""  # readable name of the function holding the block
    entry: bool = False  # the block starts at that function's first instruction


def _reg(insn, op):
    return insn.reg_name(op.reg)


def decode_block(md, code: bytes, addr: int) -> list[Insn]:
    out = []
    prev_load_dst = None  # destination of the previous single LDR (pipelining), else None
    for i in md.disasm(code, addr):
        name = _INS.get(i.id, i.mnemonic.split(".")[0])
        text = f"{i.mnemonic} {i.op_str}".strip()
        _, writes = i.regs_access()
        writes_pc = C.ARM_REG_PC in writes
        cond = i.cc not in (C.ARM_CC_AL, C.ARM_CC_INVALID)
        dynamic, dyn_regs = None, ()
        nt = 1
        next_load_dst = None
        if name in LOAD1 or name in STORE1:
            mem = [o for o in i.operands if o.type == C.ARM_OP_MEM]
            addr_regs = set()
            if mem:
                m = mem[0].mem
                addr_regs = {r for r in (m.base, m.index) if r}
            if name in LOAD1 and writes_pc:
                cost = 2 + P
            elif prev_load_dst is not None and prev_load_dst not in addr_regs:
                cost = 1
            else:
                cost = 2
            if name in LOAD1 and not writes_pc and i.operands:
                next_load_dst = i.operands[0].reg
            nt = cost
        elif name in MULTI:
            if name in ("ldrd", "strd"):
                n = 2
            else:
                n = sum(1 for o in i.operands if o.type == C.ARM_OP_REG) - (
                    1 if name in ("ldm", "ldmdb", "stm", "stmdb") else 0)
            cost = 1 + n + (P if writes_pc else 0)
            nt = 1 + n if not writes_pc else 1
        elif name in BRANCH:
            cost = (2 + P) if name in ("tbb", "tbh") else 1 + P
            nt = 1
        elif name in MULL or name in MLAL or name in DIV:
            dynamic = "mull" if name in MULL else "mlal" if name in MLAL else "div"
            regs = [o.reg for o in i.operands if o.type == C.ARM_OP_REG]
            dyn_regs = tuple(regs[-2:]) if dynamic != "div" else tuple(regs[1:3])
            cost = 0
            nt = 0
        elif name in ("mla", "mls"):
            cost = nt = 2
        else:
            # DATA_1 and everything else of ARMv7-M without an FPU: single-cycle.
            cost = 1 + (P if writes_pc else 0)
            nt = 1
        if cond and name not in BRANCH and not writes_pc:
            nt = cost
        out.append(Insn(i.address, i.size, name, text, cost, nt, dynamic, dyn_regs, cond))
        prev_load_dst = next_load_dst
    return out


def _clz(x: int) -> int:
    x &= 0xFFFF_FFFF
    return 32 - x.bit_length()


def _s32(x: int) -> int:
    x &= 0xFFFF_FFFF
    return x - (1 << 32) if x & 0x8000_0000 else x


def dynamic_cost(kind: str, signed: bool, a: int, b: int) -> int:
    if signed:
        a, b = abs(_s32(a)), abs(_s32(b))
    else:
        a, b = a & 0xFFFF_FFFF, b & 0xFFFF_FFFF
    big = (a >= 1 << 16) + (b >= 1 << 16)
    if kind == "mull":
        return 3 + big
    if kind == "mlal":
        return 4 + (0, 2, 3)[big]
    # divide: a = dividend, b = divisor
    if b == 0:
        return 2
    q = max(0, _clz(b) - _clz(a) + 1)
    return min(12, 2 + math.ceil(q / 3))


@dataclass
class Symbol:
    name: str
    addr: int
    size: int


def demangle(name: str) -> str:
    """Readable Rust legacy (`_ZN...E`) and v0 (`_R...`, crude) names; others unchanged."""
    if name.startswith("_ZN") and name.endswith("E"):
        s, i, parts = name[3:-1], 0, []
        while i < len(s) and s[i].isdigit():
            j = i
            while s[j].isdigit():
                j += 1
            n = int(s[i:j])
            parts.append(s[j:j + n])
            i = j + n
        if parts and re.fullmatch(r"h[0-9a-f]{16}", parts[-1]):
            parts.pop()
        out = "::".join(parts)
        for k, v in (("$LT$", "<"), ("$GT$", ">"), ("$RF$", "&"), ("$BP$", "*"), ("$u20$", " "),
                     ("$u27$", "'"), ("$u5b$", "["), ("$u5d$", "]"), ("$u7b$", "{"),
                     ("$u7d$", "}"), ("$C$", ","), ("$SP$", "@"), ("..", "::")):
            out = out.replace(k, v)
        return out
    if name.startswith("_R"):
        # v0 (RFC 2603): keep the path's identifiers, drop tags and crate disambiguators.
        s, i, parts = name[2:], 0, []
        while i < len(s):
            if s[i].isdigit():
                j = i
                while j < len(s) and s[j].isdigit():
                    j += 1
                n = int(s[i:j])
                if j < len(s) and s[j] == "_":
                    j += 1
                parts.append(s[j:j + n])
                i = j + n
            elif s.startswith("Cs", i):
                k = s.find("_", i)
                i = len(s) if k < 0 else k + 1
            else:
                i += 1
        return "::".join(p for p in parts if p) or name
    return name


class Elf:
    def __init__(self, path: str):
        self.path = path
        with open(path, "rb") as f:
            elf = ELFFile(f)
            self.segments = []
            for seg in elf.iter_segments():
                if seg["p_type"] != "PT_LOAD":
                    continue
                self.segments.append((seg["p_vaddr"], seg["p_paddr"], seg.data(),
                                      seg["p_memsz"]))
            self.sections = {s.name: (s["sh_addr"], s["sh_size"]) for s in elf.iter_sections()}
            # All code: `.text` and any section placed beside it (memory.x puts libgcc's
            # soft-float in `.text.softfloat`, before `.text`).
            ex = [(s["sh_addr"], s["sh_addr"] + s["sh_size"]) for s in elf.iter_sections()
                  if s["sh_flags"] & 0x4 and s["sh_size"] and s["sh_addr"]]  # SHF_EXECINSTR
            lo = min(a for a, _ in ex) if ex else FLASH_BASE
            self.code = (lo, (max(b for _, b in ex) - lo) if ex else 0)
            symtab = elf.get_section_by_name(".symtab")
            syms, objs = {}, {}
            for s in symtab.iter_symbols():
                t = s["st_info"]["type"]
                if t == "STT_FUNC" and s["st_value"]:
                    a = s["st_value"] & ~1
                    # Prefer the aeabi alias names, then the longest-sized entry.
                    old = syms.get(a)
                    if old is None or (s["st_size"] > old.size) or (
                            s.name.startswith("__aeabi") and s["st_size"] >= old.size):
                        syms[a] = Symbol(s.name, a, s["st_size"])
                elif s.name:
                    objs[s.name] = (s["st_value"], s["st_size"])
        self.funcs = sorted(syms.values(), key=lambda x: x.addr)
        self._starts = [f.addr for f in self.funcs]
        self.by_name = {f.name: f for f in self.funcs}
        self.objects = objs

    def func_at(self, addr: int) -> Symbol | None:
        i = bisect.bisect_right(self._starts, addr) - 1
        if i >= 0:
            f = self.funcs[i]
            if addr < f.addr + max(f.size, 2):
                return f
        return None

    def addr_of(self, name: str) -> int:
        if name in self.by_name:
            return self.by_name[name].addr
        return self.objects[name][0]


@dataclass
class Run:
    """One measured call: its executed blocks and the dynamic extras."""
    blocks: list = field(default_factory=list)  # (addr, size) in execution order
    dyn: dict = field(default_factory=dict)  # insn addr -> [executions, cycles]
    flash_reads: dict = field(default_factory=dict)  # pc -> count
    result: int = 0


@dataclass
class Cost:
    instructions: int = 0
    core: int = 0  # cycles at 0 wait states
    branch_miss: int = 0  # count of (a) events
    seq_stall: int = 0  # (b) cycles at the given W
    flash_reads: int = 0  # count of (c) events
    wait_states: int = 2

    @property
    def cycles(self) -> int:
        w = self.wait_states
        return self.core + w * (self.branch_miss + self.flash_reads) + self.seq_stall


class Machine:
    def __init__(self, elf_path: str):
        self.elf = Elf(elf_path)
        self.uc = unicorn.Uc(unicorn.UC_ARCH_ARM, unicorn.UC_MODE_THUMB | unicorn.UC_MODE_MCLASS)
        self.uc.ctl_set_cpu_model(A.UC_CPU_ARM_CORTEX_M3)
        self.uc.mem_map(FLASH_BASE, FLASH_SIZE, unicorn.UC_PROT_READ | unicorn.UC_PROT_EXEC)
        self.uc.mem_map(RAM_BASE, RAM_SIZE, unicorn.UC_PROT_ALL)
        ram_end = RAM_BASE
        for vaddr, paddr, data, memsz in self.elf.segments:
            self.uc.mem_write(paddr, data)
            if vaddr != paddr:
                self.uc.mem_write(vaddr, data)  # what the reset handler's .data copy does
            if RAM_BASE <= vaddr < RAM_BASE + RAM_SIZE:
                ram_end = max(ram_end, vaddr + memsz)
        self.ram_end = (ram_end + 7) & ~7
        self.stack_top = RAM_BASE + RAM_SIZE
        if "_stack_start" in self.elf.objects:
            self.stack_top = self.elf.objects["_stack_start"][0]
        # The lowest address the stack may reach: above the static data, or (flip-link, which
        # puts the stack below the static data) cortex-m-rt's `_stack_end` at the bottom of RAM.
        self.stack_bottom = self.ram_end
        if "_stack_end" in self.elf.objects:
            end = self.elf.objects["_stack_end"][0]
            if RAM_BASE <= end < self.stack_top:
                self.stack_bottom = (end + 3) & ~3
        self.uc.mem_write(RETURN_ADDR, b"\x00\xbe" * 8)  # bkpt, never reached
        self.md = capstone.Cs(capstone.CS_ARCH_ARM, capstone.CS_MODE_THUMB | capstone.CS_MODE_MCLASS)
        self.md.detail = True
        self._blocks: dict = {}
        self._dyn_sites = self._scan_dynamic()

    # -- static decode ------------------------------------------------------------------
    def _scan_dynamic(self) -> dict:
        """Addresses of long multiplies and divides in every function (linear sweep)."""
        sites = {}
        text_addr, text_size = self.elf.code
        code = bytes(self.uc.mem_read(text_addr, text_size))
        for f in self.elf.funcs:
            if not (text_addr <= f.addr < text_addr + text_size) or f.size == 0:
                continue
            off = f.addr - text_addr
            for ins in decode_block(self.md, code[off:off + f.size], f.addr):
                if ins.dynamic:
                    sites[ins.addr] = ins
        return sites

    def block(self, addr: int, size: int) -> Block:
        key = (addr, size)
        b = self._blocks.get(key)
        if b is None:
            insns = decode_block(self.md, bytes(self.uc.mem_read(addr, size)), addr)
            assert insns and insns[-1].addr + insns[-1].size == addr + size, (
                f"block {addr:#x}+{size} does not decode cleanly")
            body = sum(i.cost for i in insns[:-1])
            last = insns[-1]
            crossings = (addr + size - 1) // LINE - addr // LINE
            f = self.elf.func_at(addr)
            for i in insns:
                if i.dynamic and i.addr not in self._dyn_sites:
                    raise RuntimeError(f"{i.text} at {i.addr:#x} was not found by the scan")
            b = Block(addr, size, insns, body + last.cost, body + last.nt_cost, crossings,
                      last.addr // LINE, demangle(f.name) if f else f"?{addr:#x}",
                      bool(f and f.addr == addr))
            self._blocks[key] = b
        return b

    # -- execution ----------------------------------------------------------------------
    def read_u32(self, addr: int) -> int:
        return struct.unpack("<I", self.uc.mem_read(addr, 4))[0]

    def call(self, name_or_addr, *args, measure=False, limit=50_000_000) -> Run:
        addr = name_or_addr if isinstance(name_or_addr, int) else self.elf.addr_of(name_or_addr)
        uc = self.uc
        for r, v in zip((A.UC_ARM_REG_R0, A.UC_ARM_REG_R1, A.UC_ARM_REG_R2, A.UC_ARM_REG_R3),
                        args):
            uc.reg_write(r, v)
        uc.reg_write(A.UC_ARM_REG_SP, self.stack_top)
        uc.reg_write(A.UC_ARM_REG_LR, RETURN_ADDR | 1)
        run = Run()
        hooks = []
        if measure:
            blocks = run.blocks
            hooks.append(uc.hook_add(unicorn.UC_HOOK_BLOCK,
                                     lambda _u, a, s, _d: blocks.append((a, s))))
            dyn = run.dyn
            for site in self._dyn_sites.values():
                def on_dyn(u, a, _s, _d, site=site):
                    x = u.reg_read(_REGMAP[site.dyn_regs[0]])
                    y = u.reg_read(_REGMAP[site.dyn_regs[1]])
                    signed = site.name[0] == "s"
                    c = dynamic_cost(site.dynamic, signed, x, y)
                    e = dyn.setdefault(a, [0, 0])
                    e[0] += 1
                    e[1] += c
                hooks.append(uc.hook_add(unicorn.UC_HOOK_CODE, on_dyn, begin=site.addr,
                                         end=site.addr))
            reads = run.flash_reads

            def on_read(u, _acc, a, size, _v, _d):
                pc = u.reg_read(A.UC_ARM_REG_PC)
                reads[pc] = reads.get(pc, 0) + 1

            hooks.append(uc.hook_add(unicorn.UC_HOOK_MEM_READ, on_read, begin=FLASH_BASE,
                                     end=FLASH_BASE + FLASH_SIZE - 1))
        if hooks:
            # Unicorn instruments hooks when it translates a block: code translated before
            # the hooks were added (e.g. by ahrs_bench_select) would run unhooked.
            uc.ctl_flush_tb()
        try:
            uc.emu_start(addr | 1, RETURN_ADDR, count=limit)
        finally:
            for h in hooks:
                uc.hook_del(h)
            if hooks:
                uc.ctl_flush_tb()
        pc = uc.reg_read(A.UC_ARM_REG_PC)
        if pc & ~1 != RETURN_ADDR:
            raise RuntimeError(f"call {name_or_addr} stopped at {pc:#x}, not at the return")
        run.result = uc.reg_read(A.UC_ARM_REG_R0)
        return run

    def count_instructions_slow(self, name, *args) -> int:
        """Instruction count with a per-instruction hook (to validate the block counting)."""
        n = [0]

        def on_code(_u, _a, _s, _d):
            n[0] += 1

        h = self.uc.hook_add(unicorn.UC_HOOK_CODE, on_code)
        self.uc.ctl_flush_tb()
        try:
            self.call(name, *args)
        finally:
            self.uc.hook_del(h)
            self.uc.ctl_flush_tb()
        return n[0]

    # -- pricing ------------------------------------------------------------------------
    def price(self, run: Run, wait_states: int = 2, per_function: dict | None = None,
              block_cycles: list | None = None) -> Cost:
        """Cycles of a measured call under the model. `per_function` (name -> [calls,
        instructions, cycles]) accumulates the attribution when given; `block_cycles` receives
        each executed block's cycles (dynamic instructions at their mean cost in this run,
        flash data reads left out)."""
        w = wait_states
        cost = Cost(wait_states=w)
        dyn_mean = {a: c / n for a, (n, c) in run.dyn.items()}
        seq = run.blocks
        n = len(seq)
        fattr = per_function is not None
        for k in range(n):
            a, s = seq[k]
            b = self.block(a, s)
            nxt = seq[k + 1][0] if k + 1 < n else RETURN_ADDR
            taken = nxt != a + s
            core = b.core_taken if taken else b.core_fall
            cost.instructions += len(b.insns)
            miss = 0
            if taken:
                tline = nxt // LINE
                if k + 1 >= n or not (tline == b.last_line or tline == b.last_line + 1):
                    miss = 1
            stall = max(0, b.crossings * (1 + w) - core) if w else 0
            cost.core += core
            cost.branch_miss += miss
            cost.seq_stall += stall
            if block_cycles is not None:
                extra = sum(dyn_mean.get(i.addr, 0) for i in b.insns if i.dynamic)
                block_cycles.append(core + w * miss + stall + extra)
            if fattr:
                e = per_function.get(b.fkey)
                if e is None:
                    e = per_function[b.fkey] = [0, 0, 0]
                if b.entry:
                    e[0] += 1
                e[1] += len(b.insns)
                e[2] += core + w * miss + stall
        for a, (cnt, cyc) in run.dyn.items():
            cost.core += cyc
            if fattr:
                f = self.elf.func_at(a)
                key = demangle(f.name) if f else f"?{a:#x}"
                per_function.setdefault(key, [0, 0, 0])[2] += cyc
        for pc, cnt in run.flash_reads.items():
            cost.flash_reads += cnt
            if fattr and w:
                f = self.elf.func_at(pc)
                key = demangle(f.name) if f else f"?{pc:#x}"
                per_function.setdefault(key, [0, 0, 0])[2] += w * cnt
        return cost

    # -- stack ----------------------------------------------------------------------------
    def paint_stack(self):
        self.uc.mem_write(self.stack_bottom,
                          struct.pack("<I", PAINT) * ((self.stack_top - self.stack_bottom) // 4))

    def stack_used(self) -> int:
        data = bytes(self.uc.mem_read(self.stack_bottom, self.stack_top - self.stack_bottom))
        pat = struct.pack("<I", PAINT)
        for off in range(0, len(data), 4):
            if data[off:off + 4] != pat:
                return self.stack_top - (self.stack_bottom + off)
        return 0

    # -- flash of code ------------------------------------------------------------------
    def reachable(self, root: str) -> list[Symbol]:
        """Functions statically reachable from `root` through direct branches and calls
        (B, BL, CBZ/CBNZ, conditional B) and through function addresses built with
        MOVW/MOVT or loaded from literal pools that point at a function start."""
        text_addr, text_size = self.elf.code
        code = bytes(self.uc.mem_read(text_addr, text_size))
        seen, todo = set(), [self.elf.by_name[root]]
        while todo:
            f = todo.pop()
            if f.addr in seen:
                continue
            seen.add(f.addr)
            off = f.addr - text_addr
            movw = {}
            for i in self.md.disasm(code[off:off + f.size], f.addr):
                targets = []
                name = _INS.get(i.id, "")
                if name in ("b", "bl", "cbz", "cbnz", "blx"):
                    imm = [o.imm for o in i.operands if o.type == C.ARM_OP_IMM]
                    targets += imm
                elif name == "movw" and len(i.operands) == 2:
                    movw[i.operands[0].reg] = i.operands[1].imm
                elif name == "movt" and len(i.operands) == 2:
                    lo = movw.get(i.operands[0].reg)
                    if lo is not None:
                        targets.append(((i.operands[1].imm << 16) | lo) & ~1)
                elif name == "ldr" and i.operands and i.operands[-1].type == C.ARM_OP_MEM \
                        and i.operands[-1].mem.base == C.ARM_REG_PC:
                    lit = ((i.address + 4) & ~3) + i.operands[-1].mem.disp
                    if text_addr <= lit < text_addr + text_size - 3:
                        targets.append(struct.unpack_from("<I", code, lit - text_addr)[0] & ~1)
                for t in targets:
                    g = self.elf.func_at(t)
                    if g and g.addr != f.addr and g.addr not in seen:
                        todo.append(g)
        return [f for f in self.elf.funcs if f.addr in seen]


_REGMAP = {}
for _n in dir(C):
    if _n.startswith("ARM_REG_") and hasattr(A, "UC_" + _n):
        _REGMAP[getattr(C, _n)] = getattr(A, "UC_" + _n)


SOFT_FLOAT = re.compile(r"^(__aeabi_[fdil]|__aeabi_c[fd]|__aeabi_(ui|ul|i|l)2|__(add|sub|mul|div|neg)[sd]f3|__cmp[sd]f2|"
                        r"__(eq|ne|lt|le|gt|ge|unord)[sd]f2|__fix|__float|__extend|__trunc|"
                        r"compiler_builtins::float|compiler_builtins::int)")
LIBM = re.compile(r"^(libm::|(fmax|fmin|sqrt|atan2|atan|asin|acos|sin|cos|floor|ceil|fabs|"
                  r"rem_pio2|k_sin|k_cos)f$)")


def category(name: str) -> str:
    if SOFT_FLOAT.search(name):
        return "soft-float"
    if LIBM.search(name):
        return "libm"
    if name.startswith(("__aeabi_mem", "compiler_builtins::mem", "memcpy", "memset")):
        return "memcpy/memset"
    return "filter code"


def call_sites(m: "Machine", run: Run, block_cycles: list, callees: set, acc: dict):
    """Calls into the functions starting at `callees`, by call site: acc[(site, callee)] +=
    [calls, inclusive cycles] (cycles from the callee's entry to the return to the site's
    next instruction, nested calls included)."""
    seq = run.blocks
    stack = []  # (return address, key, cycles so far)
    for k in range(len(seq)):
        a = seq[k][0]
        while stack and a == stack[-1][0]:
            ret, key, cyc = stack.pop()
            e = acc.setdefault(key, [0, 0.0])
            e[0] += 1
            e[1] += cyc
        if k and a in callees:
            pa, ps = seq[k - 1]
            last = m.block(pa, ps).insns[-1]
            if last.name in ("bl", "blx") and not stack:
                stack.append([last.addr + last.size, (last.addr, a), 0.0])
        if stack:
            stack[-1][2] += block_cycles[k]
        # an unfinished call (cannot happen for a completed run) is dropped


class Lines:
    """Address -> (file, line) from the ELF's DWARF line programs (innermost inlined
    location, which is what the line program records)."""

    def __init__(self, path: str):
        rows = []
        with open(path, "rb") as f:
            elf = ELFFile(f)
            dw = elf.get_dwarf_info()
            for cu in dw.iter_CUs():
                lp = dw.line_program_for_CU(cu)
                if lp is None:
                    continue
                hdr = lp.header
                files = hdr["file_entry"]
                dirs = hdr["include_directory"]
                ver = hdr["version"]
                for e in lp.get_entries():
                    st = e.state
                    if st is None or st.end_sequence:
                        continue
                    idx = st.file if ver >= 5 else st.file - 1
                    if not 0 <= idx < len(files):
                        continue
                    fe = files[idx]
                    name = fe.name.decode(errors="replace")
                    d = fe.dir_index if ver >= 5 else fe.dir_index - 1
                    if 0 <= d < len(dirs):
                        name = dirs[d].decode(errors="replace") + "/" + name
                    rows.append((st.address, name, st.line))
        rows.sort()
        self.addrs = [r[0] for r in rows]
        self.rows = rows

    def at(self, addr: int):
        i = bisect.bisect_right(self.addrs, addr) - 1
        if i < 0:
            return ("?", 0)
        _, name, line = self.rows[i]
        return (name, line)
