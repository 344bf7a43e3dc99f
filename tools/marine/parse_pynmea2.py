"""Parse NMEA 0183 lines with pynmea2 (checksums checked) and print what it read, one line per
input line, tab-separated: the line's index (from 0), then `ERROR` and pynmea2's message, or the
sentence type and its values as pynmea2 interprets them:

    HDT heading        HDM heading        HDG heading variation var_dir
    ROT rate_of_turn status                XDR type:value:units:id for every transducer
    PINAH / PRDID (proprietary) the data fields

Usage: python parse_pynmea2.py FILE. Used by ahrs-tool/tests/marine.rs.
"""

import sys

import pynmea2


def describe(msg):
    kind = type(msg).__name__
    if kind == "HDT" or kind == "HDM":
        return [kind, str(msg.heading)]
    if kind == "HDG":
        return [kind, str(msg.heading), str(msg.variation), msg.var_dir]
    if kind == "ROT":
        return [kind, msg.rate_of_turn, msg.status]
    if kind == "XDR":
        out = [kind]
        for i in range(msg.num_transducers):
            t = msg.get_transducer(i)
            out.append(":".join([t.type, t.value, t.units, t.id]))
        return out
    if isinstance(msg, pynmea2.ProprietarySentence):
        return ["P" + msg.manufacturer + "".join(msg.data[:1])] + list(msg.data[1:])
    return [kind] + list(msg.data)


def main(path):
    with open(path, encoding="ascii") as f:
        for i, line in enumerate(f):
            try:
                fields = describe(pynmea2.parse(line.strip(), check=True))
            except Exception as e:  # every failure is reported, never skipped
                fields = ["ERROR", repr(e).replace("\t", " ")]
            print("\t".join([str(i)] + ["" if x is None else str(x) for x in fields]))


if __name__ == "__main__":
    main(sys.argv[1])
