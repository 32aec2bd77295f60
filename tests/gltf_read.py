# gltf_read.py: read_gltf(PATH) -> (json, images) for a .glb or a .gltf with
# embedded (data URI) buffers; images maps each image's name to its PNG bytes.
# Standard library only; imported by cli_export_test.sh's checks.
import base64, json, struct

def read_gltf(path):
    data = open(path, "rb").read()
    if data[:4] == b"glTF":
        n = struct.unpack("<I", data[12:16])[0]
        doc = json.loads(data[20:20 + n])
        pos = 20 + n
        m = struct.unpack("<I", data[pos:pos + 4])[0]
        buffers = [data[pos + 8:pos + 8 + m]]
    else:
        doc = json.loads(data)
        buffers = [base64.b64decode(b["uri"].split(",", 1)[1]) for b in doc["buffers"]]
    def view(i):
        v = doc["bufferViews"][i]
        o = v.get("byteOffset", 0)
        return buffers[v["buffer"]][o:o + v["byteLength"]]
    images = {im["name"]: view(im["bufferView"]) for im in doc["images"]}
    return doc, images, view
