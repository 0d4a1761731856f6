#!/bin/sh
# A user's round trip on a few of the trial's volumes: kinds37's script, the same steps.
#   sh results/kinds39/roundtrip.sh DIR OUTDIR NAME[:REL] ...
exec sh "$(dirname "$0")/../kinds37/roundtrip.sh" "$@"
