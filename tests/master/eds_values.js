#!/usr/bin/env node
/*
 * The values an independent EDS reader (the npm package `canopen`, its Eds
 * class) gives each object of a device description: one line per entry,
 *   <index hex> <sub hex> <data type hex> <value bytes hex, '-' for none>
 * or "SKIP <index> <sub> <why>" for what the package does not evaluate
 * ($NODEID terms), or a single "ERROR <message>" when it refuses the file.
 * tests/unit/eds_test.cpp (EdsForeign) compares these with the SDO uploads
 * of a cansimd node built from the same file.
 */
'use strict';

const { Eds, DataType } = require('canopen');

// What the package does not evaluate as CiA 306 means it: $NODEID terms (it
// has none), DOMAIN (no buffer), a REAL written as IEEE 754 bits (it takes
// "0x3E6B851F" as the number 1047234847).
function skipped(obj) {
    const v = typeof obj.defaultValue === 'string' ? obj.defaultValue : '';
    if (/\$nodeid/i.test(v))
        return '$NODEID';
    if (obj.dataType === DataType.DOMAIN || obj.raw === undefined)
        return 'DOMAIN';
    if ((obj.dataType === DataType.REAL32 || obj.dataType === DataType.REAL64) && /^\s*0x/i.test(v))
        return 'REAL-as-bits';
    return null;
}

function line(obj, index, sub) {
    const hex = (v, w) => v.toString(16).toUpperCase().padStart(w, '0');
    const why = skipped(obj);
    if (why) {
        console.log(`SKIP ${hex(index, 4)} ${hex(sub, 2)} ${why}`);
        return;
    }
    const raw = obj.raw;
    console.log(`${hex(index, 4)} ${hex(sub, 2)} ${hex(obj.dataType, 2)} ${raw.length ? raw.toString('hex') : '-'}`);
}

let eds;
try {
    eds = Eds.fromFile(process.argv[2]);
} catch (e) {
    console.log(`ERROR ${e.message}`);
    process.exit(0);
}
for (const [key, obj] of eds.entries()) {
    const index = parseInt(key, 16);
    if (!obj.subNumber) {
        line(obj, index, 0);
        continue;
    }
    for (let sub = 0; sub < 256; ++sub) {
        const s = obj.at(sub);
        if (s !== undefined && s !== null) line(s, index, sub);
    }
}
