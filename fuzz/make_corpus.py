#!/usr/bin/env python3
"""Writes the JSON-world and glTF seeds of fuzz/corpus/ and the files of fuzz/data/ from what is
already on a drtv machine: the tree's world files and test snippets, Debian's assimp-testmodels
(glTF 2.0 test set) and tests/assets. glTF files with external .bin buffers are rewritten
with the buffers embedded as data: URIs (the fuzz target resolves no files). Only files up to
kMaxBytes are taken: the corpus stays small. Sector and archive seeds come from
drtv_fuzz_make_seeds (fuzz/make_seeds.cpp). Usage: fuzz/make_corpus.py (from anywhere)."""
import base64, json, os, pathlib, re, shutil, struct, zlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
FUZZ = ROOT / "fuzz"
ASSIMP = pathlib.Path("/usr/share/assimp/models/glTF2")
TEST_ASSETS = ROOT / "tests" / "assets"
kMaxBytes = 24 * 1024


def embed(gltf_path):
    """The glTF's JSON with every external buffer as a data: URI, or None if one is missing."""
    doc = json.loads(gltf_path.read_text())
    for buf in doc.get("buffers", []):
        uri = buf.get("uri", "")
        if uri and not uri.startswith("data:"):
            bin_path = gltf_path.parent / uri
            if not bin_path.is_file():
                return None
            buf["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bin_path.read_bytes()).decode()
    for img in doc.get("images", []):  # images only refine the albedo: drop external ones
        if "uri" in img and not img["uri"].startswith("data:"):
            del img["uri"]
    return json.dumps(doc, separators=(",", ":")).encode()


def png16(width, height, pixel):
    """A 16-bit greyscale PNG (for the heightmap terrain)."""
    rows = b"".join(b"\0" + b"".join(struct.pack(">H", pixel(x, y)) for x in range(width)) for y in range(height))
    chunk = lambda kind, data: struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def main():
    gltf_dir = FUZZ / "corpus" / "gltf"
    json_dir = FUZZ / "corpus" / "world_json"
    data_dir = FUZZ / "data"
    for d in (gltf_dir, json_dir, data_dir):
        shutil.rmtree(d, ignore_errors=True)
        d.mkdir(parents=True)

    # glTF seeds: every small assimp glTF 2.0 test file (valid and deliberately broken), the
    # shared assets' small files (Draco among them).
    sources = sorted(ASSIMP.rglob("*.gl*")) + sorted(TEST_ASSETS.rglob("*.gl*"))
    for src in sources:
        if src.suffix not in (".gltf", ".glb"):
            continue
        name = re.sub(r"[^A-Za-z0-9_.-]", "_", str(src.relative_to(src.parents[1])))
        if src.suffix == ".glb":
            data = src.read_bytes()
        else:
            try:
                data = embed(src)
            except (ValueError, UnicodeDecodeError):
                data = src.read_bytes()  # deliberately broken JSON: a seed as it is
            if data is None:
                continue
        if len(data) <= kMaxBytes:
            (gltf_dir / name).write_bytes(data)

    # Files the world seeds refer to, relative to fuzz/data/.
    shutil.copy(TEST_ASSETS / "draco_box" / "Box_Draco.glb", data_dir / "box.glb")
    (data_dir / "plane.gltf").write_bytes(embed(ASSIMP / "glTF-Asset-Generator" / "Mesh_PrimitiveMode" / "Mesh_PrimitiveMode_00.gltf"))
    (data_dir / "heightmap.png").write_bytes(png16(17, 17, lambda x, y: (x * 3000 + y * 800) % 65536))

    # World seeds: the tree's worlds, the reference scene, and every JSON snippet of the tests.
    for src in sorted((ROOT / "worlds").glob("*.json")) + sorted((ROOT / "tests").rglob("*.json")):
        shutil.copy(src, json_dir / src.name)
    snippets = set()
    for test in sorted((ROOT / "tests" / "worlds").glob("*.cpp")):
        for m in re.finditer(r'R"\((.*?)\)"', test.read_text(), re.S):
            snippets.add(m.group(1))
    for i, s in enumerate(sorted(snippets)):
        (json_dir / f"test_snippet_{i:03d}.json").write_text(s)
    extra = {
        "gltf_refs.json": {"gltf": [{"path": "box.glb", "class": "static", "scale": 2},
                                    {"path": "plane.gltf", "translation": [5, 0, 0], "rotation_z_deg": 30}]},
        "heightmap.json": {"terrain": {"kind": "heightmap", "path": "heightmap.png", "size_m": 64, "height_m": 10},
                           "vegetation": [{"count": 20, "mesh": {"gltf": "box.glb"}, "scale": [0.5, 2]}]},
        "everything.json": {"name": "all", "terrain": {"kind": "noise", "size_m": 64, "resolution_m": 4, "height_m": 5},
                            "primitives": [{"shape": "sphere", "albedo": [0.5, 0.5, 0.5], "class": "dynamic"}],
                            "vegetation": [{"count": 5, "seed": 3, "mesh": {"primitive": "box", "size": [1, 1, 2]}}],
                            "lights": [{"name": "l", "position": [1, 2, 3], "intensity": [1, 1, 1], "radius_m": 5}],
                            "interiors": [{"min": [0, 0, 0], "max": [2, 2, 2], "probe": [1, 1, 1], "blend_m": 0.5}],
                            "effects": ["sun_bounce", "sky_bounce"],
                            "sky": {"latitude_deg": 40, "sun_irradiance": [[6, 1, 1, 1], [12, 2, 2, 2]]}},
        "small_island.json": {"island": {"size_km2": 0.01, "grid_spacing_m": 2, "trees_per_km2": 10000,
                                         "rocks_per_km2": 1000, "buildings_per_km2": 500, "walls_per_km2": 500}},
    }
    for name, doc in extra.items():
        (json_dir / name).write_text(json.dumps(doc))


if __name__ == "__main__":
    main()
