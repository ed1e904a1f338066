placeholder = None
class ContactSpec: pass
