#!/usr/bin/env python3
"""Writes the STL, OFF and glTF files of tests/data/good and tests/data/bad (issue 33).
Every good file holds the unit quad (0,0,0) (1,0,0) (1,1,0) (0,1,0), triangles (0,1,2)
(0,2,3), unless its name says otherwise; every bad file is named after its defect.
Run from the repository root: tests/data/make_format_corpus.py"""
import base64
import json
import os
import struct

GOOD, BAD = "tests/data/good", "tests/data/bad"
Q = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
T = [(0, 1, 2), (0, 2, 3)]


def put(d, name, data):
    with open(os.path.join(d, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


# ---- STL ----
def stl_bin(tris, count=None, header=b"quad"):
    out = header.ljust(80, b" ") + struct.pack("<I", len(tris) if count is None else count)
    for c in tris:
        out += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *p) for p in c) + b"\0\0"
    return out


def stl_ascii(tris, name="quad"):
    s = "solid %s\n" % name
    for c in tris:
        s += "  facet normal 0 0 1\n    outer loop\n"
        for p in c:
            s += "      vertex %s %s %s\n" % p
        s += "    endloop\n  endfacet\n"
    return s + "endsolid %s\n" % name


quad = [[Q[i] for i in t] for t in T]
put(GOOD, "quad_binary.stl", stl_bin(quad))
put(GOOD, "quad_binary_header_says_solid.stl", stl_bin(quad, header=b"solid quad (binary, header starts like ASCII)"))
put(GOOD, "quad_ascii.stl", stl_ascii(quad))
put(GOOD, "quad_ascii_crlf_uppercase.stl", stl_ascii(quad).upper().replace("\n", "\r\n"))
put(BAD, "stl_lying_count_binary.stl", stl_bin(quad, count=5))
put(BAD, "stl_lying_low_count_binary.stl", stl_bin(quad, count=1))
put(BAD, "stl_huge_count_tiny_file.stl", stl_bin(quad, count=0xFFFFFFFF))
put(BAD, "stl_truncated_header.stl", b"\0" * 50)
put(BAD, "stl_zero_triangles.stl", stl_bin([]))
put(BAD, "stl_nan_vertex_binary.stl", stl_bin([[Q[0], Q[1], (float("nan"), 0, 0)]]))
put(BAD, "stl_inf_vertex_binary.stl", stl_bin([[Q[0], (float("inf"), 0, 0), Q[2]]]))
put(BAD, "stl_nan_vertex_ascii.stl", stl_ascii(quad).replace("vertex 1 1 0", "vertex 1 nan 0", 1))
put(BAD, "stl_ascii_truncated_in_facet.stl", stl_ascii(quad)[:120])
put(BAD, "stl_ascii_without_endsolid.stl", stl_ascii(quad).replace("endsolid quad\n", ""))
put(BAD, "stl_ascii_facet_with_four_vertices.stl",
    stl_ascii(quad).replace("      vertex 1 1 0\n    endloop", "      vertex 1 1 0\n      vertex 0 1 0\n    endloop", 1))
put(BAD, "stl_ascii_facet_with_two_vertices.stl", stl_ascii(quad).replace("      vertex 1 1 0\n", "", 1))
put(BAD, "stl_ascii_malformed_number.stl", stl_ascii(quad).replace("vertex 1 0 0", "vertex 1,5 0 0", 1))
put(BAD, "stl_ascii_vertex_with_two_coordinates.stl", stl_ascii(quad).replace("vertex 1 0 0", "vertex 1 0", 1))
put(BAD, "stl_ascii_no_facets.stl", "solid empty\nendsolid empty\n")
put(BAD, "stl_ascii_missing_outer_loop.stl", stl_ascii(quad).replace("    outer loop\n", "", 1))

# ---- OFF ----
def off(head="OFF", verts=Q, faces=[(4, 0, 1, 2, 3)], counts=None, vextra="", fextra=""):
    nv, nf = (len(verts), len(faces)) if counts is None else counts
    s = "%s\n%d %d 0\n" % (head, nv, nf)
    s += "".join("%s %s %s%s\n" % (p + (vextra,)) for p in verts)
    s += "".join(" ".join(map(str, f)) + fextra + "\n" for f in faces)
    return s


put(GOOD, "quad.off", off(faces=[(3, 0, 1, 2), (3, 0, 2, 3)]))
put(GOOD, "quad_polygon.off", off())
put(GOOD, "quad_comments_counts_in_keyword.off",
    "# a comment before the keyword\nOFF4 1 0 # Princeton style\n\n" + "".join("%s %s %s  # v\n" % p for p in Q) + "4 0 1 2 3\n")
put(GOOD, "quad_colors.off", "COFF\n4 2 0\n" + "".join("%s %s %s 255 0 0 255\n" % p for p in Q) +
    "3 0 1 2 0 255 0\n3 0 2 3 0.0 0.0 1.0\n")
put(BAD, "off_index_out_of_range.off", off(faces=[(3, 0, 1, 4)]))
put(BAD, "off_negative_index.off", off(faces=[(3, 0, -1, 2)]))
put(BAD, "off_lying_face_count.off", off(counts=(4, 3)))
put(BAD, "off_lying_vertex_count.off", off(counts=(5, 1)))
put(BAD, "off_data_after_last_face.off", off() + "3 0 1 2\n")
put(BAD, "off_nan_vertex.off", off(verts=[Q[0], ("nan", 0, 0), Q[2], Q[3]]))
put(BAD, "off_face_with_two_vertices.off", off(faces=[(2, 0, 1)]))
put(BAD, "off_face_shorter_than_its_count.off", off(faces=[(4, 0, 1, 2)]))
put(BAD, "off_huge_count_tiny_file.off", off(counts=(4, 4000000000)))
put(BAD, "off_malformed_number.off", off(verts=[Q[0], ("1,5", 0, 0), Q[2], Q[3]]))
put(BAD, "off_vertex_with_two_coordinates.off", "OFF\n4 1 0\n0 0 0\n1 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
put(BAD, "off_zero_faces.off", off(faces=[]))
put(BAD, "off_binary_unsupported.off", "OFF BINARY\n" + "\0" * 40)
put(BAD, "off_missing_counts.off", "OFF\n")
put(BAD, "off_colour_300.off", "COFF\n4 1 0\n" + "".join("%s %s %s 300 0 0 255\n" % p for p in Q) + "4 0 1 2 3\n")

# ---- glTF ----
def gltf_doc(positions=Q, indices=[0, 1, 2, 0, 2, 3], mode=None, extra=None, index_type=5125, nodes=None):
    vb = b"".join(struct.pack("<3f", *p) for p in positions)
    fmt = {5121: "<B", 5123: "<H", 5125: "<I"}[index_type]
    ib = b"".join(struct.pack(fmt, i) for i in indices)
    ib += b"\0" * (-len(ib) % 4)
    prim = {"attributes": {"POSITION": 0}, "indices": 1}
    if mode is not None:
        prim["mode"] = mode
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes or [{"mesh": 0}],
        "meshes": [{"primitives": [prim]}],
        "buffers": [{"byteLength": len(vb) + len(ib)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(vb)},
                        {"buffer": 0, "byteOffset": len(vb), "byteLength": len(ib)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3"},
                      {"bufferView": 1, "componentType": index_type, "count": len(indices), "type": "SCALAR"}],
    }
    if extra:
        extra(doc)
    return doc, vb + ib


def embedded(doc, data):
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    return json.dumps(doc, indent=1)


def glb(doc, data, length=None):
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    data += b"\0" * (-len(data) % 4)
    total = 12 + 8 + len(js) + 8 + len(data)
    return (struct.pack("<III", 0x46546C67, 2, total if length is None else length) +
            struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(data), 0x004E4942) + data)


put(GOOD, "quad.gltf", embedded(*gltf_doc()))
put(GOOD, "quad.glb", glb(*gltf_doc()))
put(GOOD, "quad_ushort_indices.glb", glb(*gltf_doc(index_type=5123)))
put(GOOD, "quad_strip.gltf", embedded(*gltf_doc(indices=[1, 2, 0, 3], mode=5)))
put(GOOD, "quad_fan.gltf", embedded(*gltf_doc(indices=[0, 1, 2, 3], mode=6)))
d, b = gltf_doc()
d["buffers"][0]["uri"] = "quad_external.bin"
put(GOOD, "quad_external.gltf", json.dumps(d, indent=1))
put(GOOD, "quad_external.bin", b)


def two_instances(doc):
    # Node 0: translated by (10, 0, 0); its child node 1: scaled by 2 (so at 10 + 2x);
    # node 2: rotated 90 degrees about z (x -> y) with a red material.
    doc["nodes"] = [{"mesh": 0, "translation": [10, 0, 0], "children": [1]},
                    {"mesh": 0, "scale": [2, 2, 2]},
                    {"mesh": 1, "rotation": [0, 0, 0.7071067811865476, 0.7071067811865476]}]
    doc["scenes"] = [{"nodes": [0, 2]}]
    doc["meshes"].append({"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]})
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}}]


put(GOOD, "quad_three_instances.gltf", embedded(*gltf_doc(extra=two_instances)))
put(GOOD, "quad_mirrored.gltf", embedded(*gltf_doc(nodes=[{"mesh": 0, "scale": [-1, 1, 1]}])))


def vertex_colours(doc):
    cb = b"".join(struct.pack("<4B", *c) for c in [(255, 0, 0, 255), (0, 255, 0, 255), (0, 0, 255, 255), (255, 255, 255, 255)])
    n = doc["buffers"][0]["byteLength"]
    doc["bufferViews"].append({"buffer": 0, "byteOffset": n, "byteLength": len(cb)})
    doc["accessors"].append({"bufferView": 2, "componentType": 5121, "normalized": True, "count": 4, "type": "VEC4"})
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = 2
    doc["meshes"][0]["primitives"][0]["material"] = 0
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 1, 1]}}]
    doc["buffers"][0]["byteLength"] = n + len(cb)
    doc["_extra_bytes"] = base64.b64encode(cb).decode()


d, b = gltf_doc(extra=vertex_colours)
b += base64.b64decode(d.pop("_extra_bytes"))
put(GOOD, "quad_vertex_colours.glb", glb(d, b))


def out_of_view(doc):
    doc["accessors"][0]["count"] = 5


def view_outside_buffer(doc):
    doc["bufferViews"][1]["byteLength"] = 400


def node_cycle(doc):
    doc["nodes"] = [{"mesh": 0, "children": [1]}, {"children": [0]}]


def sparse(doc):
    doc["accessors"][0]["sparse"] = {"count": 1}


def draco(doc):
    doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]


def version1(doc):
    doc["asset"]["version"] = "1.0"


def offset_past_view(doc):
    doc["accessors"][1]["byteOffset"] = 4


put(BAD, "gltf_accessor_outside_buffer_view.gltf", embedded(*gltf_doc(extra=out_of_view)))
put(BAD, "gltf_accessor_offset_past_buffer_view.gltf", embedded(*gltf_doc(extra=offset_past_view)))
put(BAD, "gltf_buffer_view_outside_buffer.gltf", embedded(*gltf_doc(extra=view_outside_buffer)))
put(BAD, "gltf_index_out_of_range.gltf", embedded(*gltf_doc(indices=[0, 1, 4])))
put(BAD, "gltf_index_count_not_multiple_of_3.gltf", embedded(*gltf_doc(indices=[0, 1, 2, 3])))
put(BAD, "gltf_nan_position.gltf", embedded(*gltf_doc(positions=[Q[0], (float("nan"), 0, 0), Q[2], Q[3]])))
put(BAD, "gltf_node_cycle.gltf", embedded(*gltf_doc(extra=node_cycle)))
put(BAD, "gltf_sparse_accessor_unsupported.gltf", embedded(*gltf_doc(extra=sparse)))
put(BAD, "gltf_draco_required_unsupported.gltf", embedded(*gltf_doc(extra=draco)))
put(BAD, "gltf_version_1.gltf", embedded(*gltf_doc(extra=version1)))
d, b = gltf_doc()
put(BAD, "gltf_malformed_json.gltf", embedded(d, b)[:-3] + ",]}")
txt = embedded(d, b)
put(BAD, "gltf_bad_base64.gltf", txt.replace("base64,", "base64,!!", 1))
put(BAD, "gltf_base64_shorter_than_byte_length.gltf", txt.replace('"byteLength": %d' % len(b), '"byteLength": %d' % (len(b) + 100), 1))
d2 = json.loads(txt)
d2["buffers"][0]["uri"] = "no_such_buffer.bin"
put(BAD, "gltf_external_buffer_missing.gltf", json.dumps(d2))
d3, b3 = gltf_doc()
d3["buffers"][0]["uri"] = "/etc/passwd"
put(BAD, "gltf_absolute_buffer_path.gltf", json.dumps(d3))
put(BAD, "glb_truncated.glb", glb(*gltf_doc())[:-20])
put(BAD, "glb_lying_length.glb", glb(*gltf_doc(), length=4000))
put(BAD, "glb_json_chunk_past_end.glb", glb(*gltf_doc())[:12] + struct.pack("<II", 100000, 0x4E4F534A) + glb(*gltf_doc())[20:])
put(BAD, "glb_header_only.glb", struct.pack("<III", 0x46546C67, 2, 12))
d4, b4 = gltf_doc()
d4["buffers"][0]["byteLength"] = len(b4) + 64
put(BAD, "glb_buffer_longer_than_bin_chunk.glb", glb(d4, b4))
put(BAD, "gltf_no_triangles.gltf", embedded(*gltf_doc(mode=1, indices=[0, 1])))
# Found by fuzz_off: triangles whose POSITION accessor has no vertices.
put(BAD, "gltf_triangles_over_zero_positions.gltf", embedded(*gltf_doc(positions=[])))
