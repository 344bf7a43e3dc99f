// Parse NMEA 0183 lines with Signal K's parser (@signalk/nmea0183-signalk) and print the
// Signal K values it produced, one line per input line, tab-separated: the line's index (from
// 0), then `null` (no delta: a sentence the parser has no handler for, or one it refused, such
// as ROT with status V), `ERROR` and the message, or `path=value` for every value of the delta.
//
// Usage: node parse_signalk.js FILE (NODE_PATH naming the node_modules with the parser). Used
// by ahrs-tool/tests/marine.rs.
'use strict'
const fs = require('fs')
const Parser = require('@signalk/nmea0183-signalk')

const parser = new Parser()
const lines = fs.readFileSync(process.argv[2], 'ascii').split('\n')
if (lines[lines.length - 1] === '') lines.pop()
const out = []
lines.forEach((line, i) => {
  let fields
  try {
    const delta = parser.parse(line.trim())
    if (!delta) {
      fields = ['null']
    } else {
      fields = []
      for (const u of delta.updates || []) {
        for (const v of u.values || []) fields.push(`${v.path}=${JSON.stringify(v.value)}`)
      }
    }
  } catch (e) {
    fields = ['ERROR', String(e && e.message).replace(/\t/g, ' ')]
  }
  out.push([String(i)].concat(fields).join('\t'))
})
process.stdout.write(out.join('\n') + '\n')
