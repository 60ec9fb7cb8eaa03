"""Assembles a labelled contact sheet: contact_sheet.py SRC_DIR OUT.png NAME...
reads SRC_DIR/NAME.png for each NAME, four to a row, each labelled with its
NAME. Needs Pillow."""
import sys
from PIL import Image, ImageDraw

src, dst, names = sys.argv[1], sys.argv[2], sys.argv[3:]
tiles = [Image.open(f"{src}/{n}.png").convert("RGB") for n in names]
w, h = tiles[0].size
cols, label = min(4, len(tiles)), 22
rows = (len(tiles) + cols - 1) // cols
sheet = Image.new("RGB", (cols * w, rows * (h + label)), "white")
draw = ImageDraw.Draw(sheet)
for i, (name, tile) in enumerate(zip(names, tiles)):
    x, y = (i % cols) * w, (i // cols) * (h + label)
    sheet.paste(tile, (x, y))
    draw.text((x + 6, y + h + 5), name, fill="black")
sheet.save(dst, optimize=True)
print(f"wrote {dst} ({sheet.size[0]}x{sheet.size[1]})")
