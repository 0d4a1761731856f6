"""qver26: which payload each brick of the given .vpk files takes (bytes per path), by
wrapping the bounded codec's brick decoder; prints one line a file."""
import collections
import sys

from volpack import api
from volpack.volume_codec import lossless, lossy

seen = collections.Counter()
orig = lossy.BoundedCodec._decode


def name(data) -> str:
    flags, inner = data[0], bytes(lossy._take(memoryview(data), 1, len(data))[0])
    if flags & lossy.FLAG_EXACT:
        return "exact:" + lossless.describe(inner)
    if flags & lossy.FLAG_INTERP:
        return "interp"
    if flags & lossy.FLAG_CDF97:
        return "cdf97"
    if flags & lossy.FLAG_COEF:
        return "coef"
    if flags & lossy.FLAG_RESIDUALS:
        return "longfit"
    return "qvox:" + lossless.describe(inner)


def wrapped(self, data, shape, dtype, into):
    seen[name(bytes(data))] += len(data)
    return orig(self, data, shape, dtype, into)


lossy.BoundedCodec._decode = wrapped
for path in sys.argv[1:]:
    seen.clear()
    api.decompress_array(open(path, "rb").read(), workers=1)
    print(path.rsplit("/", 1)[-1], " ".join(f"{k}={v}" for k, v in sorted(seen.items())))
