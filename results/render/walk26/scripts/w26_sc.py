import time, sys, pickle
import numpy as np
from volpack.octree import Octree
from volpack.octree.reader import _node_chunks, selection_chunks
tree = Octree('/work/lead/walk/o.vpk')
nodes = pickle.load(open('/tmp/w26_sel.pkl', 'rb'))
g = tree.geometry
border = lambda lv: 1 if lv > 0 else 0
t = time.perf_counter(); a = set().union(*(_node_chunks(g, lv, b, border(lv)) for lv, b in nodes)); t1 = time.perf_counter()
b = selection_chunks(g, nodes, border); t2 = time.perf_counter()
print(len(nodes), len(a), a == b, "union (first, uncached) %.1f ms, selection_chunks %.1f ms" % ((t1 - t) * 1e3, (t2 - t1) * 1e3))
