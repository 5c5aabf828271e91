/*
 * Bob Jenkins' lookup3 hashlittle (public domain, 2006): the checksum of HDF5's version 2 object
 * headers and their continuation chunks, which latdyn's own HDF5 writer (latdyn/results/hdf5_writer.py)
 * puts in state.h5. Runtime code, written by hand: no physics. latdyn_lookup3 is the writer's
 * lookup3 (the Python reference, which tests/test_hdf5_writer.py holds it to) in C: the data
 * read as little-endian 32-bit words whatever the machine's byte order, the last block (1 to 12
 * bytes) padded with zeros.
 */
#include <stdint.h>

#define LATDYN_ROT(x, k) (((x) << (k)) | ((x) >> (32 - (k))))

static uint32_t lookup3_word(const unsigned char *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

uint32_t latdyn_lookup3(const unsigned char *data, int64_t n, uint32_t initval)
{
    uint32_t a, b, c;
    a = b = c = 0xDEADBEEFu + (uint32_t)n + initval;
    if (n == 0) return c;
    while (n > 12) {
        a += lookup3_word(data);
        b += lookup3_word(data + 4);
        c += lookup3_word(data + 8);
        a -= c; a ^= LATDYN_ROT(c, 4);  c += b;
        b -= a; b ^= LATDYN_ROT(a, 6);  a += c;
        c -= b; c ^= LATDYN_ROT(b, 8);  b += a;
        a -= c; a ^= LATDYN_ROT(c, 16); c += b;
        b -= a; b ^= LATDYN_ROT(a, 19); a += c;
        c -= b; c ^= LATDYN_ROT(b, 4);  b += a;
        data += 12;
        n -= 12;
    }
    unsigned char last[12] = {0};
    for (int64_t i = 0; i < n; ++i) last[i] = data[i];
    a += lookup3_word(last);
    b += lookup3_word(last + 4);
    c += lookup3_word(last + 8);
    c ^= b; c -= LATDYN_ROT(b, 14);
    a ^= c; a -= LATDYN_ROT(c, 11);
    b ^= a; b -= LATDYN_ROT(a, 25);
    c ^= b; c -= LATDYN_ROT(b, 16);
    a ^= c; a -= LATDYN_ROT(c, 4);
    b ^= a; b -= LATDYN_ROT(a, 14);
    c ^= b; c -= LATDYN_ROT(b, 24);
    return c;
}

#undef LATDYN_ROT
