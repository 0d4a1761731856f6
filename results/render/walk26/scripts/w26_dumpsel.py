"""The MRI walk's first selection pickled to /tmp/w26_sel.pkl (for w26_sc.py)."""
import pickle, sys
sys.argv = [sys.argv[0], "time"]
exec(open('/tmp/w26_prof_upd.py').read().split("mode = sys.argv[1]")[0])
pickle.dump([(int(lv), tuple(int(i) for i in b)) for lv, b in sel], open('/tmp/w26_sel.pkl', 'wb'))
