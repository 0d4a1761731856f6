import sys

from PIL import Image, ImageDraw

files = sys.argv[2:]
n = len(files)
cols = min(4, n)
rows = (n + cols - 1) // cols
W = 256
m = Image.new("RGB", (cols * W, rows * (W + 14)), (40, 40, 40))
d = ImageDraw.Draw(m)
for i, f in enumerate(files):
    im = Image.open(f).convert("RGB")
    im.thumbnail((W, W))
    x, y = (i % cols) * W, (i // cols) * (W + 14)
    m.paste(im, (x, y + 14))
    d.text((x + 2, y), f.split("/")[-1], fill=(255, 255, 0))
m.save(sys.argv[1])
